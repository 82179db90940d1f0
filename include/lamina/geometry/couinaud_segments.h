#pragma once
/// \file
/// Couinaud's eight liver segments from the vessels (issue 63), as the planners place them
/// (Bismuth 1982; Fasel et al. 1998; Oliveira et al. 2011): the three hepatic veins run in the
/// vertical scissurae that divide the liver into four sectors around the vena cava (right
/// posterior 6+7, right anterior 5+8, left medial 4, left lateral 2+3), and transverse planes at
/// the portal vein's level divide the sectors into superior and inferior segments. The caudate
/// lobe, segment 1, lies about the vena cava around that level.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "lamina/core/grid.h"
#include "lamina/geometry/vessel_graph.h"

namespace lamina::geometry {

/// What placed the segments' planes.
enum class CouinaudPlacement {
  kVessels,  ///< the centrelines' landmarks (couinaud_segments)
  kAtlas,    ///< the experts' planes in the organ's box (couinaud_segments_from_atlas)
};

/// Where the segments' planes were placed (physical mm; z superior).
struct CouinaudLandmarks {
  CouinaudPlacement placed_by = CouinaudPlacement::kVessels;
  /// The vena cava's axis at the hepatic veins' confluence (the widest vessel in the organ's
  /// upper quarter): the vertical axis of the scissurae.
  Eigen::Vector3d confluence_mm = Eigen::Vector3d::Zero();
  /// The right, middle and left hepatic veins' azimuths about that axis, degrees from the
  /// patient's right towards anterior (right 0, anterior 90, left 180).
  std::array<double, 3> vein_azimuth_deg{};
  /// The portal vein's level: the height of the wide, nearly horizontal vessels across the
  /// organ's middle (its right and left branches at the hilum), mm: the left transverse plane
  /// (2 above 3).
  double portal_level_mm = 0.0;
  /// The right transverse plane (8 above 5, 7 above 6), mm.
  double right_level_mm = 0.0;
};

struct CouinaudSegments {
  std::vector<uint8_t> segment;       ///< per voxel of the organ's grid: 1-8, 0 outside it
  std::array<double, 9> volume_ml{};  ///< per segment 1-8 ([0] unused)
  CouinaudLandmarks landmarks;
};

/// The segments of `organ` placed by an atlas: the planes the experts of 3D-IRCADb-01 drew
/// (fitted to their labels of 20 livers: docs/resection.md), their mean position as shares of
/// the organ's bounding box (the scissurae's axis at 0.63 of its width from the patient's right
/// and 0.59 of its depth from the front; the right, middle and left planes at -1, 40 and 73
/// degrees; the left and right transverse planes at 0.65 and 0.51 of its height). Measured
/// against those labels leave-one-out (each liver placed by the other 19's mean) it scores a
/// mean Dice of 0.735, against 0.57 for the landmarks found on their merged vessel masks: the
/// placement for vessels that come as one label. Needs only the organ, so it never fails on a
/// non-empty mask.
/// \note Throws lamina::Error (kInvalidInput) naming `name` when `organ` is empty.
CouinaudSegments couinaud_segments_from_atlas(const Mask& organ, const std::string& name);

/// The segments of `organ` from its vessels' centrelines: the portal vein and the hepatic veins,
/// as one graph (one label holding both, or the union of the two trees' graphs).
/// \note Throws lamina::Error (kInvalidInput) naming `name` when the landmarks are not found: no
///   vessel in the organ's upper quarter, no wide horizontal vessel across its middle, fewer
///   than three hepatic-vein trunks above the portal level.
CouinaudSegments couinaud_segments(const Mask& organ, const VesselGraph& vessels,
                                   const std::string& name);

}  // namespace lamina::geometry
