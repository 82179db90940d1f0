#pragma once
// What couinaud_segments.cpp and couinaud_atlas.cpp share: the azimuth convention and every
// organ voxel's segment from the landmarks.
#include <Eigen/Core>

#include "lamina/geometry/couinaud_segments.h"
#include "vessel_internal.h"

namespace lamina::geometry::detail {

/// Degrees from the patient's right (-x in LPS) towards anterior (-y) about the vertical line
/// through `axis`, in [-90, 270).
double azimuth_deg(const Eigen::Vector3d& p, const Eigen::Vector3d& axis);

/// Fills out.segment and out.volume_ml from out.landmarks: by each organ voxel's azimuth about
/// the scissurae's axis, right of the right plane 6/7, between right and middle 5/8, between
/// middle and left 4, beyond the left 2/3; 7 above 6 and 8 above 5 at the right level, 2 above
/// 3 at the portal level; segment 1 about the axis around the portal level.
void place_segments(const Mask& organ, const Heights& heights, CouinaudSegments& out);

/// The right transverse plane's height share for the left one's (the experts' mean offset).
double right_level_share(double portal_share);

/// One liver of the compiled-in atlas (couinaud_atlas.cpp): its labels 0-8 on a g^3 grid in its
/// own bounding box (x to the patient's left, y to the back, z up; z fastest, then y, x).
struct AtlasLiver {
  int g = 0;
  int lits_number = 0;
  const uint8_t* labels = nullptr;
};
int atlas_liver_count();
AtlasLiver atlas_liver(int index);

}  // namespace lamina::geometry::detail
