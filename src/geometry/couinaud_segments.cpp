// Couinaud's segments (couinaud_segments.h): the confluence, the portal level and the three
// hepatic veins found on the centrelines, then every organ voxel classified by its azimuth about
// the confluence's vertical axis and its height. Heights are fractions of the organ's height.
#include "lamina/geometry/couinaud_segments.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "lamina/core/error.h"
#include "vessel_internal.h"

namespace lamina::geometry {
namespace {

constexpr double kDeg = 180.0 / std::numbers::pi;
// The confluence: the widest vessel above this share of the organ's height.
constexpr double kUpperQuarter = 0.75;
// Wide horizontal vessels below this height are portal (the hepatic veins' trunks run higher),
// unless they leave the confluence (within this distance of it, mm).
constexpr double kPortalBelow = 0.8;
constexpr double kTrunkFromConfluenceMm = 20.0;
// The hepatic veins' trunks are looked for this far from the axis (mm): beyond the vena cava's
// radius, within the veins' main course.
constexpr double kVeinFromMm = 10.0, kVeinToMm = 60.0;
// and fan out in front of the vena cava: azimuths from 45 degrees behind the right to 45 behind
// the left.
constexpr double kVeinAzimuthLo = -45.0, kVeinAzimuthHi = 225.0;
constexpr double kVeinsApartDeg = 25.0;
// Calibrated on 3D-IRCADb's expert labels (docs/resection.md): their right transverse plane
// lies 0.14 of the organ's height below the left one (0.51 and 0.65 of it on average), and
// segment 1 within 35 mm of their scissurae's axis, from 0.18 below to 0.11 above the left
// transverse plane (the means of the planes fitted to their 20 livers' labels).
constexpr double kRightBelowLeft = 0.14;
constexpr double kCaudateRadiusMm = 35.0, kCaudateBelow = 0.18, kCaudateAbove = 0.11;

// Degrees from the patient's right (-x in LPS) towards anterior (-y) about the vertical line
// through `axis`, in [-90, 270).
double azimuth_deg(const Eigen::Vector3d& p, const Eigen::Vector3d& axis) {
  double a = std::atan2(-(p.y() - axis.y()), -(p.x() - axis.x())) * kDeg;
  if (a < -90.0) a += 360.0;
  return a;
}

// Fills out.segment and out.volume_ml from out.landmarks: by each organ voxel's azimuth about
// the scissurae's axis, right of the right plane 6/7, between right and middle 5/8, between
// middle and left 4, beyond the left 2/3; 7 above 6 and 8 above 5 at the right level, 2 above
// 3 at the portal level; segment 1 about the axis around the portal level.
void place_segments(const Mask& organ, const detail::Heights& heights, CouinaudSegments& out) {
  const CouinaudLandmarks& lm = out.landmarks;
  const GridFrame& f = organ.frame;
  const double height = heights.hi - heights.lo;
  const double caudate_lo = lm.portal_level_mm - kCaudateBelow * height,
               caudate_hi = lm.portal_level_mm + kCaudateAbove * height;
  out.segment.assign(organ.inside.size(), 0);
  out.volume_ml = {};
  const double voxel_ml = f.voxel_volume_mm3() / 1000.0;
  for (int64_t v = 0; v < f.voxel_count(); ++v) {
    if (organ.inside[static_cast<size_t>(v)] == 0) continue;
    const Eigen::Vector3d p = detail::voxel_centre_mm(f, v);
    const double a = azimuth_deg(p, lm.confluence_mm);
    const double r = std::hypot(p.x() - lm.confluence_mm.x(), p.y() - lm.confluence_mm.y());
    uint8_t s = 0;
    if (r < kCaudateRadiusMm && p.z() > caudate_lo && p.z() < caudate_hi)
      s = 1;
    else if (a < lm.vein_azimuth_deg[0])
      s = p.z() >= lm.right_level_mm ? 7 : 6;
    else if (a < lm.vein_azimuth_deg[1])
      s = p.z() >= lm.right_level_mm ? 8 : 5;
    else if (a < lm.vein_azimuth_deg[2])
      s = 4;
    else
      s = p.z() >= lm.portal_level_mm ? 2 : 3;
    out.segment[static_cast<size_t>(v)] = s;
    out.volume_ml[s] += voxel_ml;
  }
}

// The right transverse plane's height share for the left one's (the experts' mean offset).
double right_level_share(double portal_share) {
  return portal_share - kRightBelowLeft;
}

}  // namespace

CouinaudSegments couinaud_segments(const Mask& organ, const VesselGraph& vessels,
                                   const std::string& name) {
  CouinaudSegments out;
  CouinaudLandmarks& lm = out.landmarks;

  // The organ's height.
  const detail::Heights heights = detail::organ_heights(organ);
  const double z_lo = heights.lo, height = heights.hi - heights.lo;
  const auto share = [&](double z) { return heights.share(z); };

  // The confluence: the node in the upper quarter where the most cross-section meets (where the
  // hepatic veins reach the vena cava).
  const GridFrame& vf = vessels.frame;
  std::vector<double> meeting(vessels.nodes.size(), 0.0);
  for (const VesselGraph::Branch& b : vessels.branches)
    for (const int32_t n : {b.a, b.b}) meeting[static_cast<size_t>(n)] += b.radius_mm * b.radius_mm;
  double widest = 0.0;
  for (size_t n = 0; n < vessels.nodes.size(); ++n)
    if (share(vessels.nodes[n].position_mm.z()) > kUpperQuarter && meeting[n] > widest) {
      widest = meeting[n];
      lm.confluence_mm = vessels.nodes[n].position_mm;
    }
  if (widest <= 0.0)
    throw invalid_input(name,
                        "Couinaud's segments: no vessel in the organ's upper quarter (the "
                        "hepatic veins' confluence)");

  // The portal level: the median height of the wide, nearly horizontal branches, each weighted
  // by its cross-section, its length and the fourth power of its horizontality.
  std::vector<std::pair<double, double>> levels;  // height share, weight
  for (const VesselGraph::Branch& b : vessels.branches) {
    if (b.voxels.size() < 4) continue;
    // The hepatic veins' trunks, which leave the confluence, are not the portal vein's.
    if ((vessels.nodes[static_cast<size_t>(b.a)].position_mm - lm.confluence_mm).norm() <
            kTrunkFromConfluenceMm ||
        (vessels.nodes[static_cast<size_t>(b.b)].position_mm - lm.confluence_mm).norm() <
            kTrunkFromConfluenceMm)
      continue;
    const Eigen::Vector3d first = detail::voxel_centre_mm(vf, b.voxels.front());
    const Eigen::Vector3d chord = detail::voxel_centre_mm(vf, b.voxels.back()) - first;
    const double length = chord.norm();
    if (length < 5.0) continue;
    double mean_z = 0.0;
    for (const int64_t v : b.voxels) mean_z += detail::voxel_centre_mm(vf, v).z();
    const double level = share(mean_z / static_cast<double>(b.voxels.size()));
    if (level > kPortalBelow) continue;
    const double horizontal = 1.0 - std::abs(chord.z()) / length;
    levels.emplace_back(level, b.radius_mm * b.radius_mm * length * std::pow(horizontal, 4));
  }
  double total = 0.0;
  for (const auto& l : levels) total += l.second;
  if (total <= 0.0)
    throw invalid_input(name,
                        "Couinaud's segments: no wide horizontal vessel across the organ's "
                        "middle (the portal vein's branches)");
  std::sort(levels.begin(), levels.end());
  double portal = levels.back().first, sum = 0.0;
  for (const auto& l : levels)
    if ((sum += l.second) >= 0.5 * total) {
      portal = l.first;
      break;
    }
  lm.portal_level_mm = z_lo + portal * height;
  lm.right_level_mm = z_lo + right_level_share(portal) * height;

  // The hepatic veins: the three strongest peaks of the centrelines' azimuths above the portal
  // level, each voxel weighted by its branch's cross-section.
  constexpr int kBins = 72;  // 5 degrees
  std::array<double, kBins> histogram{};
  for (const VesselGraph::Branch& b : vessels.branches)
    for (const int64_t v : b.voxels) {
      const Eigen::Vector3d p = detail::voxel_centre_mm(vf, v);
      const double r = std::hypot(p.x() - lm.confluence_mm.x(), p.y() - lm.confluence_mm.y());
      if (p.z() <= lm.portal_level_mm || r <= kVeinFromMm || r >= kVeinToMm) continue;
      const int bin = std::clamp(static_cast<int>((azimuth_deg(p, lm.confluence_mm) + 90.0) / 5.0),
                                 0, kBins - 1);
      histogram[static_cast<size_t>(bin)] += b.radius_mm * b.radius_mm;
    }
  std::array<double, kBins> smooth{};
  for (int i = 0; i < kBins; ++i)
    for (int d = -2; d <= 2; ++d)
      smooth[static_cast<size_t>(i)] += histogram[static_cast<size_t>((i + d + kBins) % kBins)];
  const auto at = [&](int i) { return smooth[static_cast<size_t>((i + kBins) % kBins)]; };
  std::vector<int> peaks;
  for (int i = 0; i < kBins; ++i) {
    const double azimuth = i * 5.0 - 90.0;
    if (azimuth >= kVeinAzimuthLo && azimuth <= kVeinAzimuthHi && at(i) > 0.0 &&
        at(i) >= at(i + 1) && at(i) >= at(i - 1))
      peaks.push_back(i);
  }
  std::stable_sort(peaks.begin(), peaks.end(), [&](int a, int b) { return at(a) > at(b); });
  std::vector<int> chosen;
  for (const int p : peaks) {
    bool apart = true;
    for (const int c : chosen) apart = apart && std::abs(p - c) * 5.0 >= kVeinsApartDeg;
    if (apart) chosen.push_back(p);
    if (chosen.size() == 3) break;
  }
  if (chosen.size() < 3)
    throw invalid_input(name,
                        "Couinaud's segments: fewer than three hepatic-vein trunks above the "
                        "portal level");
  std::sort(chosen.begin(), chosen.end());
  for (size_t v = 0; v < 3; ++v) lm.vein_azimuth_deg[v] = chosen[v] * 5.0 + 2.5 - 90.0;

  // Every organ voxel by its azimuth about the confluence's axis and its height.
  lm.placed_by = CouinaudPlacement::kVessels;
  place_segments(organ, heights, out);
  return out;
}

}  // namespace lamina::geometry
