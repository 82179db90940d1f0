// Couinaud's segments placed by an atlas (couinaud_segments.h): the experts' planes, their mean
// over 3D-IRCADb-01's 20 livers as shares of each organ's bounding box, put in this organ's box.
#include <array>
#include <limits>

#include "couinaud_internal.h"
#include "lamina/core/error.h"
#include "lamina/geometry/couinaud_segments.h"

namespace lamina::geometry {
namespace {

// The planes fitted to the expert labels of 3D-IRCADb-01 (docs/resection.md, "Couinaud's
// segments"): per liver, the three scissurae's lines (each the boundary voxels between two
// neighbouring sectors, its principal direction in the axial plane), their least-squares common
// point (the axis) and the mean heights of the 2|3 and 7|6, 8|5 boundaries; then the mean over
// the 20 livers. The axis as shares of the box from the patient's right (x) and from the front
// (y); azimuths in degrees from the right towards anterior; the portal (left transverse) level
// as a share of the organ's height from its bottom. Spread over the livers (standard
// deviation): axis 0.09 and 0.06 of the box, azimuths 5, 8 and 14 degrees, level 0.05.
constexpr double kAxisFromRight = 0.631, kAxisFromFront = 0.591;
constexpr std::array<double, 3> kAzimuthDeg{-1.2, 39.5, 73.3};
constexpr double kPortalShare = 0.650;

}  // namespace

CouinaudSegments couinaud_segments_from_atlas(const Mask& organ, const std::string& name) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(kInf), hi = Eigen::Vector3d::Constant(-kInf);
  for (int64_t v = 0; v < organ.frame.voxel_count(); ++v)
    if (organ.inside[static_cast<size_t>(v)] != 0) {
      const Eigen::Vector3d p = detail::voxel_centre_mm(organ.frame, v);
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  if (!(lo.x() <= hi.x()))
    throw invalid_input(name, "Couinaud's segments: the organ has no voxels");
  const detail::Heights heights{lo.z(), hi.z()};
  CouinaudSegments out;
  CouinaudLandmarks& lm = out.landmarks;
  lm.placed_by = CouinaudPlacement::kAtlas;
  // LPS: x grows towards the patient's left, y towards the back.
  // The axis's point at the portal level stands for the confluence.
  const double height = hi.z() - lo.z();
  lm.portal_level_mm = lo.z() + kPortalShare * height;
  lm.confluence_mm = {lo.x() + kAxisFromRight * (hi.x() - lo.x()),
                      lo.y() + kAxisFromFront * (hi.y() - lo.y()), lm.portal_level_mm};
  lm.vein_azimuth_deg = kAzimuthDeg;
  lm.right_level_mm = lo.z() + detail::right_level_share(kPortalShare) * height;
  detail::place_segments(organ, heights, out);
  return out;
}

}  // namespace lamina::geometry
