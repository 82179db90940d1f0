// Couinaud's segments (couinaud_segments.h): the portal tree walked down its widest subtrees to
// its main and right bifurcations, the hepatic veins' trunks found as the three peaks of their
// centrelines' azimuths about the confluence, then every organ voxel classified by its azimuth
// and height.
#include "lamina/geometry/couinaud_segments.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "lamina/core/error.h"
#include "vessel_internal.h"

namespace lamina::geometry {
namespace {

constexpr double kDeg = 180.0 / std::numbers::pi;

// Degrees from the patient's right (-x in LPS) towards anterior (-y), in [-90, 270).
double azimuth_deg(const Eigen::Vector3d& p, const Eigen::Vector3d& axis) {
  double a = std::atan2(-(p.y() - axis.y()), -(p.x() - axis.x())) * kDeg;
  if (a < -90.0) a += 360.0;
  return a;
}

struct Subtrees {
  std::vector<std::vector<int32_t>> children;
  std::vector<double> length;             // each branch's subtree's centreline, mm
  std::vector<Eigen::Vector3d> centroid;  // its length-weighted centre
};

Subtrees subtrees(const VesselTree& t) {
  const VesselGraph& g = t.graph;
  Subtrees s;
  s.children.resize(g.branches.size());
  s.length.assign(g.branches.size(), 0.0);
  s.centroid.assign(g.branches.size(), Eigen::Vector3d::Zero());
  for (const int32_t b : t.order)
    if (t.parent[static_cast<size_t>(b)] >= 0)
      s.children[static_cast<size_t>(t.parent[static_cast<size_t>(b)])].push_back(b);
  for (auto it = t.order.rbegin(); it != t.order.rend(); ++it) {
    const auto b = static_cast<size_t>(*it);
    const VesselGraph::Branch& br = g.branches[b];
    const Eigen::Vector3d mid = 0.5 * (g.nodes[static_cast<size_t>(br.a)].position_mm +
                                       g.nodes[static_cast<size_t>(br.b)].position_mm);
    s.length[b] += br.length_mm;
    s.centroid[b] += br.length_mm * mid;
    const int32_t p = t.parent[b];
    if (p >= 0) {
      s.length[static_cast<size_t>(p)] += s.length[b];
      s.centroid[static_cast<size_t>(p)] += s.centroid[b];
    }
  }
  for (size_t b = 0; b < s.centroid.size(); ++b)
    if (s.length[b] > 0.0) s.centroid[b] /= s.length[b];
  return s;
}

// The far node of branch b (away from the root).
const Eigen::Vector3d& far_end(const VesselTree& t, int32_t b) {
  const VesselGraph::Branch& br = t.graph.branches[static_cast<size_t>(b)];
  const int32_t far = t.from_node[static_cast<size_t>(b)] == br.a ? br.b : br.a;
  return t.graph.nodes[static_cast<size_t>(far)].position_mm;
}

// From branch b down its largest subtrees to the first branch whose two largest children each
// hold at least `share` of its subtree: returns that branch (-1 when none), and its children.
int32_t main_bifurcation(const Subtrees& s, int32_t b, double share, std::array<int32_t, 2>& kids) {
  while (b >= 0) {
    std::vector<int32_t> c = s.children[static_cast<size_t>(b)];
    if (c.empty()) return -1;
    std::sort(c.begin(), c.end(), [&](int32_t x, int32_t y) {
      return s.length[static_cast<size_t>(x)] > s.length[static_cast<size_t>(y)];
    });
    if (c.size() >= 2 &&
        s.length[static_cast<size_t>(c[1])] >= share * s.length[static_cast<size_t>(b)]) {
      kids = {c[0], c[1]};
      return b;
    }
    b = c[0];
  }
  return -1;
}

}  // namespace

CouinaudSegments couinaud_segments(const Mask& organ, const VesselTree& portal,
                                   const VesselTree& hepatic, const std::string& name) {
  CouinaudSegments out;
  CouinaudLandmarks& lm = out.landmarks;

  // The portal bifurcations: from the widest branch leaving the root.
  const Subtrees ps = subtrees(portal);
  int32_t trunk = -1;
  for (const int32_t b : portal.order)
    if (portal.parent[static_cast<size_t>(b)] < 0 &&
        (trunk < 0 || ps.length[static_cast<size_t>(b)] > ps.length[static_cast<size_t>(trunk)]))
      trunk = b;
  std::array<int32_t, 2> kids{};
  const int32_t main = trunk < 0 ? -1 : main_bifurcation(ps, trunk, 0.2, kids);
  if (main < 0)
    throw invalid_input(name, "Couinaud's segments: the portal vein's bifurcation is not found");
  lm.portal_bifurcation_mm = far_end(portal, main);
  // The right branch: the child whose subtree lies further to the patient's right (-x).
  const int32_t right =
      ps.centroid[static_cast<size_t>(kids[0])].x() < ps.centroid[static_cast<size_t>(kids[1])].x()
          ? kids[0]
          : kids[1];
  std::array<int32_t, 2> right_kids{};
  const int32_t right_split = main_bifurcation(ps, right, 0.2, right_kids);
  lm.right_portal_bifurcation_mm =
      right_split >= 0 ? far_end(portal, right_split) : lm.portal_bifurcation_mm;

  // The hepatic veins' trunks: peaks of their centrelines' azimuths above the portal
  // bifurcation, each voxel weighted by its branch's cross-section.
  if (hepatic.roots.empty())
    throw invalid_input(name, "Couinaud's segments: the hepatic veins have no root");
  lm.confluence_mm = hepatic.graph.nodes[static_cast<size_t>(hepatic.roots[0])].position_mm;
  constexpr int kBins = 72;  // 5 degrees
  std::array<double, kBins> histogram{};
  for (const int32_t b : hepatic.order) {
    const VesselGraph::Branch& br = hepatic.graph.branches[static_cast<size_t>(b)];
    for (const int64_t v : br.voxels) {
      const Eigen::Vector3d p = detail::voxel_centre_mm(hepatic.graph.frame, v);
      const double r = std::hypot(p.x() - lm.confluence_mm.x(), p.y() - lm.confluence_mm.y());
      if (p.z() < lm.portal_bifurcation_mm.z() || r < 10.0) continue;
      const int bin = std::clamp(static_cast<int>((azimuth_deg(p, lm.confluence_mm) + 90.0) / 5.0),
                                 0, kBins - 1);
      histogram[static_cast<size_t>(bin)] += br.radius_mm * br.radius_mm;
    }
  }
  std::array<double, kBins> smooth{};
  for (int i = 0; i < kBins; ++i)
    for (int d = -2; d <= 2; ++d)
      smooth[static_cast<size_t>(i)] += histogram[static_cast<size_t>((i + d + kBins) % kBins)];
  std::vector<int> peaks;
  for (int i = 0; i < kBins; ++i) {
    const double here = smooth[static_cast<size_t>(i)];
    if (here <= 0.0 || here < smooth[static_cast<size_t>((i + 1) % kBins)] ||
        here < smooth[static_cast<size_t>((i + kBins - 1) % kBins)])
      continue;
    peaks.push_back(i);
  }
  std::sort(peaks.begin(), peaks.end(), [&](int a, int b) {
    return smooth[static_cast<size_t>(a)] > smooth[static_cast<size_t>(b)];
  });
  std::vector<int> chosen;
  for (const int p : peaks) {
    bool apart = true;
    for (const int c : chosen) apart = apart && std::abs(p - c) >= 5;  // 25 degrees
    if (apart) chosen.push_back(p);
    if (chosen.size() == 3) break;
  }
  if (chosen.size() < 3)
    throw invalid_input(name,
                        "Couinaud's segments: fewer than three hepatic-vein trunks above the "
                        "portal bifurcation");
  std::sort(chosen.begin(), chosen.end());
  for (int v = 0; v < 3; ++v)
    lm.vein_azimuth_deg[static_cast<size_t>(v)] = chosen[static_cast<size_t>(v)] * 5.0 + 2.5 - 90.0;

  // Every organ voxel by its azimuth about the confluence's axis and its height.
  const GridFrame& f = organ.frame;
  out.segment.assign(organ.inside.size(), 0);
  const double voxel_ml = f.voxel_volume_mm3() / 1000.0;
  const double z_left = lm.portal_bifurcation_mm.z(), z_right = lm.right_portal_bifurcation_mm.z();
  for (int64_t k = 0; k < f.size[2]; ++k)
    for (int64_t j = 0; j < f.size[1]; ++j)
      for (int64_t i = 0; i < f.size[0]; ++i) {
        const auto v = static_cast<size_t>(f.index(i, j, k));
        if (organ.inside[v] == 0) continue;
        const Eigen::Vector3d p = detail::voxel_centre_mm(f, static_cast<int64_t>(v));
        const double a = azimuth_deg(p, lm.confluence_mm);
        uint8_t s = 0;
        if (a < lm.vein_azimuth_deg[0])
          s = p.z() >= z_right ? 7 : 6;
        else if (a < lm.vein_azimuth_deg[1])
          s = p.z() >= z_right ? 8 : 5;
        else if (a < lm.vein_azimuth_deg[2])
          s = 4;
        else
          s = p.z() >= z_left ? 2 : 3;
        out.segment[v] = s;
        out.volume_ml[s] += voxel_ml;
      }
  return out;
}

}  // namespace lamina::geometry
