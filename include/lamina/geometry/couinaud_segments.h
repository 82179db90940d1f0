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
  kAtlas,    ///< expert-labelled livers like it, in the organ's box (couinaud_segments_from_atlas)
};

/// Where the segments' planes were placed (physical mm; z superior); for the atlas, which of
/// its livers voted instead (the plane fields are then unset: zero).
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
  /// The atlas's livers that voted (their LiTS numbers), most alike first.
  std::vector<int> atlas_livers;
  /// Their shapes' mean overlap (Dice) with the organ's, each in its box: how alike they were.
  double atlas_overlap = 0.0;
  /// Whether the organ's vessels lined the voters up inside it (then only the atlas's livers
  /// whose vessels are known voted).
  bool atlas_vessels = false;
};

struct CouinaudSegments {
  std::vector<uint8_t> segment;       ///< per voxel of the organ's grid: 1-8, 0 outside it
  std::array<double, 9> volume_ml{};  ///< per segment 1-8 ([0] unused)
  CouinaudLandmarks landmarks;
};

/// The segments of `organ` placed by an atlas: the expert Couinaud labels of 111 livers of the
/// LiTS challenge (xukun-zhang/Couinaud-Segmentation; data/PROVENANCE.md), compiled in, 17 of
/// them with their vessels. Each liver is held in its own bounding box on a 40^3 grid; the 10
/// whose shapes overlap this organ's most in its box (each moved by up to 3 bins to fit) are
/// each bent onto its outline (demons), and with `vessels` (the portal and hepatic veins, one
/// mask or their union, on the organ's grid) only the livers whose vessels are known take part
/// and each is then bent further so its vessels meet the organ's; they vote for every bin, the
/// votes are smoothed (a Gaussian of one bin) and every organ voxel takes the segment with the
/// most votes where it lies. Measured against 3D-IRCADb-01's expert labels (20 livers, none of
/// them in the atlas): docs/resection.md. Needs only the organ, so it never fails on a
/// non-empty mask; the organ's axes are taken as LPS (x to the patient's left, y to the back,
/// z up), as the readers give them.
/// \note Throws lamina::Error (kInvalidInput) naming `name` when `organ` is empty, or `vessels`
///   is not on its grid or has no voxel inside it.
CouinaudSegments couinaud_segments_from_atlas(const Mask& organ, const std::string& name,
                                              const Mask* vessels = nullptr);

/// The segments of `organ` from its vessels' centrelines: the portal vein and the hepatic veins,
/// as one graph (one label holding both, or the union of the two trees' graphs).
/// \note Throws lamina::Error (kInvalidInput) naming `name` when the landmarks are not found: no
///   vessel in the organ's upper quarter, no wide horizontal vessel across its middle, fewer
///   than three hepatic-vein trunks above the portal level.
CouinaudSegments couinaud_segments(const Mask& organ, const VesselGraph& vessels,
                                   const std::string& name);

}  // namespace lamina::geometry
