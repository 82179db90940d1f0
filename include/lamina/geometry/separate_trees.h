#pragma once
/// \file
/// One vessel label holding both the portal vein and the hepatic veins (3D-IRCADb's, MSD task
/// 8's "hepatic vessel") split into its two trees (issue 63). In a segmentation the two touch
/// where they pass close: thin false connections between two systems of wide vessels. They are
/// cut where the connections between the two trees' trunks are narrowest (a minimum cut of
/// the centreline graph, each branch's capacity its cross-section).

#include <cstdint>
#include <string>

#include "lamina/core/grid.h"
#include "lamina/geometry/vessel_graph.h"

namespace lamina::geometry {

struct SeparatedTrees {
  VesselGraph portal, hepatic;  ///< each with its own nodes and branches, the merged graph's grid
  int32_t cut_branches = 0;     ///< connections between the two cut
  double cut_area_mm2 = 0.0;    ///< their cross-sections' sum
  /// Centreline of pieces joined to neither trunk (after the gaps are bridged), given to the
  /// tree nearest them.
  double assigned_by_distance_mm = 0.0;
};

/// Splits `merged` (vessel_graph() of one label holding both trees; its gaps are bridged first)
/// into the portal vein and the hepatic veins, on the organ's anatomy (z physical, superior):
/// the hepatic veins' trunk is the widest vessel reaching the organ's outside in its upper
/// quarter (where they drain into the vena cava); the portal vein's is the widest, most nearly
/// horizontal vessel in its middle (its right and left branches at the hilum). The graph is cut
/// between the two at the least total cross-section (Boost.Graph's Boykov-Kolmogorov maximum
/// flow); pieces joined to neither go to the tree whose centreline is nearest.
/// @param[in] organ  the organ's mask, on the graph's grid or a crop of it
/// \note Throws lamina::Error (kInvalidInput) naming `name` when no trunk of one tree is found
///   ("trees cannot be separated: ...").
SeparatedTrees separate_trees(VesselGraph merged, const Mask& organ, const std::string& name);

}  // namespace lamina::geometry
