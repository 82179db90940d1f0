#pragma once
/// \file
/// What the functional remnant needs of a vessel tree wherever its tissue lies (an organ's
/// voxels, a model's tetrahedra): the flow from seed to seed and the branches (issue 63).

#include <cstdint>
#include <string>
#include <vector>

#include "lamina/geometry/structure_names.h"

namespace lamina::geometry {

struct TreeFlow {
  std::string name;  ///< the vessel's (the structure's name)
  VesselTreeKind kind = VesselTreeKind::kPortal;
  int32_t roots = 0, bridged_gaps = 0;
  double unrooted_mm = 0.0;  ///< centreline in no tree
  /// Per seed (a centreline point, each after the one upstream of it): the seed before it on the
  /// way to the root (-1 at a root), and its branch.
  std::vector<int32_t> seed_upstream, seed_branch;
  /// Per branch: the branch upstream of it (-1 at a root or in no tree), whether it is in a tree
  /// at all, its centreline's length and mean radius, and the tissue it feeds or drains.
  std::vector<int32_t> branch_parent;
  std::vector<uint8_t> branch_rooted;
  std::vector<double> branch_length_mm, branch_radius_mm, branch_territory_ml;
  size_t seeds() const { return seed_upstream.size(); }
  size_t branches() const { return branch_parent.size(); }
};

/// Per seed: whether it still connects to its root when the seeds `blocked` says are cut off:
/// its own and every seed upstream of it unblocked.
std::vector<uint8_t> still_connected(const TreeFlow& flow, const std::vector<uint8_t>& blocked);

}  // namespace lamina::geometry
