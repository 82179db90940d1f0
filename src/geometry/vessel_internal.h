#pragma once
// Shared by the vessel graph, tree and separation (internal to src/geometry): a voxel's centre
// from its linear index (they keep voxels as linear indices of the mask's grid), and whether a
// point is near the organ's outside (where a tree leaves it).

#include <Eigen/Core>
#include <array>
#include <cstdint>

#include "lamina/core/grid.h"

namespace lamina::geometry::detail {

inline Eigen::Vector3d voxel_centre_mm(const GridFrame& f, int64_t v) {
  const int64_t i = v % f.size[0], j = (v / f.size[0]) % f.size[1], k = v / (f.size[0] * f.size[1]);
  const std::array<double, 3> p =
      f.to_physical(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k));
  return {p[0], p[1], p[2]};
}

/// Whether a voxel outside `organ` (or beyond its grid) lies within `reach_mm` of `p`.
bool near_outside(const Mask& organ, const Eigen::Vector3d& p, double reach_mm);

}  // namespace lamina::geometry::detail
