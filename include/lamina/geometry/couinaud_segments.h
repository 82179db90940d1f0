#pragma once
/// \file
/// Couinaud's eight liver segments from the vessel trees (issue 63), as the planners place them
/// (Bismuth 1982; Fasel et al. 1998; Oliveira et al. 2011): the three hepatic veins run in the
/// vertical scissurae that divide the liver into four sectors around the vena cava (right
/// posterior 6+7, right anterior 5+8, left medial 4, left lateral 2+3), and transverse planes at
/// the portal vein's bifurcations divide the sectors into superior and inferior segments. The
/// caudate lobe, segment 1, lies behind the portal bifurcation against the vena cava.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "lamina/core/grid.h"
#include "lamina/geometry/vessel_tree.h"

namespace lamina::geometry {

/// Where the segments' planes were placed (physical mm; z superior).
struct CouinaudLandmarks {
  /// The hepatic veins' confluence (their tree's root): the vertical axis of the scissurae.
  Eigen::Vector3d confluence_mm = Eigen::Vector3d::Zero();
  /// The right, middle and left hepatic veins' azimuths about that axis, degrees from the
  /// patient's right towards anterior (right 0, anterior 90, left 180).
  std::array<double, 3> vein_azimuth_deg{};
  /// The portal vein's main bifurcation: the left transverse plane (2 above 3).
  Eigen::Vector3d portal_bifurcation_mm = Eigen::Vector3d::Zero();
  /// The right portal vein's bifurcation: the right transverse plane (8 above 5, 7 above 6).
  Eigen::Vector3d right_portal_bifurcation_mm = Eigen::Vector3d::Zero();
};

struct CouinaudSegments {
  std::vector<uint8_t> segment;       ///< per voxel of the organ's grid: 1-8, 0 outside it
  std::array<double, 9> volume_ml{};  ///< per segment 1-8 ([0] unused)
  CouinaudLandmarks landmarks;
};

/// The segments of `organ` from its portal and hepatic trees (rooted: vessel_tree()).
/// \note Throws lamina::Error (kInvalidInput) naming `name` when the landmarks are not found:
///   fewer than three hepatic-vein trunks above the portal bifurcation, or no portal
///   bifurcation.
CouinaudSegments couinaud_segments(const Mask& organ, const VesselTree& portal,
                                   const VesselTree& hepatic, const std::string& name);

}  // namespace lamina::geometry
