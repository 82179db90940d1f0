#pragma once
/// \file
/// A vessel skeleton as a graph (issue 63, second stage): its junctions and ends are nodes, the
/// curves between them branches, each with its length and radius, in millimetres. The vessel
/// trees, their territories and Couinaud's segments are made on it.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "lamina/geometry/skeletonize.h"

namespace lamina::geometry {

struct VesselGraph {
  struct Node {
    Eigen::Vector3d position_mm;  ///< the mean of its voxels' centres
    double radius_mm = 0.0;       ///< its widest voxel's
    int32_t degree = 0;           ///< branches ending here (a loop counts twice)
    std::vector<int64_t> voxels;  ///< the skeleton voxels it stands for (a junction: several)
  };
  struct Branch {
    int32_t a = -1, b = -1;       ///< its nodes (a == b: a closed loop)
    std::vector<int64_t> voxels;  ///< the skeleton voxels between them, from a's side to b's
    double length_mm = 0.0;       ///< along its voxels (smoothed), from node a's position to b's
    double radius_mm = 0.0;       ///< the median of its voxels' radii (its nodes' if it has none)
  };
  GridFrame frame;
  std::vector<Node> nodes;
  std::vector<Branch> branches;
};

/// The graph of `skeleton`: a node for every end (one neighbour), every isolated voxel and every
/// cluster of touching junction voxels (three neighbours or more), and one on each closed loop
/// that has none; a branch for every curve of two-neighbour voxels between two nodes, and for two
/// nodes that touch.
/// @param[in] skeleton  skeletonize()'s (26-connected curves)
VesselGraph vessel_graph(const Skeleton& skeleton);

}  // namespace lamina::geometry
