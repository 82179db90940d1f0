#pragma once
/// \file
/// The territory of each branch of a vessel tree (issue 63): the organ's voxels nearest to its
/// centreline, as the planners assign tissue to the vessel that feeds or drains it (Selle et
/// al. 2002, MeVis). A territory of a subtree is the union of its branches'.

#include <cstdint>
#include <vector>

#include "lamina/core/grid.h"
#include "lamina/geometry/vessel_graph.h"

namespace lamina::geometry {

/// Each voxel of `organ` given the branch of `graph` whose centreline voxel is nearest to it
/// (exact Euclidean distance, the grid's spacing per axis). A junction's voxels count for its
/// widest branch; a node without branches counts for none.
/// @param[in] organ  the organ's mask (the liver), on the grid the graph was made on
/// @param[in] graph  vessel_graph()'s, of the same grid
/// @return per voxel of the grid: the branch's index, -1 outside the organ (and everywhere when
///   the graph has no branch)
/// \note Throws lamina::Error (kInvalidInput) when the graph is of another grid than the organ.
std::vector<int32_t> branch_territories(const Mask& organ, const VesselGraph& graph);

}  // namespace lamina::geometry
