#pragma once
/// \file
/// A rooted vessel tree's territories on the organ's grid (issue 63), made once and then asked,
/// for any resection, which tissue it still feeds or drains: every organ voxel belongs to the
/// centreline voxel nearest it (Selle et al. 2002), and a centreline voxel keeps its flow when
/// none on its way to the root lies in the organ on the resected side.

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "lamina/core/grid.h"
#include "lamina/geometry/vessel_tree.h"

namespace lamina::geometry {

struct TreeTerritories {
  std::string name;  ///< the vessel's (the structure's name)
  VesselTree tree;
  /// The tree's centreline voxels (its grid's linear indices), each after the one upstream of
  /// it: a root's node first, then each branch's voxels from its from-node on, then the node it
  /// reaches (when the branch is the one that reaches it).
  std::vector<int64_t> seeds;
  std::vector<int32_t> seed_upstream;  ///< per seed: the seed before it on the way to the root
  std::vector<int32_t> seed_branch;    ///< per seed: its branch (a node's: the branch reaching it)
  /// Per voxel of the organ's grid: the nearest seed, -1 outside the organ.
  std::vector<int32_t> seed_of;
  /// Per branch: its territory's voxel count (the organ's voxels it feeds or drains).
  std::vector<int64_t> branch_voxels;
};

/// The territories of `tree` in `organ`: an exact feature transform from the tree's centreline
/// voxels (branches in no tree left out: their tissue goes to the nearest one that is).
/// \note Throws lamina::Error (kInvalidInput) naming `name` when the tree is of another grid
///   than the organ's, and when no centreline voxel of the tree lies in the organ ("no voxel
///   inside the organ").
TreeTerritories tree_territories(const Mask& organ, VesselTree tree, const std::string& name);

}  // namespace lamina::geometry
