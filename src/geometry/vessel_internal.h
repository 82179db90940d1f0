#pragma once
// Shared by the vessel graph, tree, separation and segments (internal to src/geometry): a voxel's
// centre from its linear index (they keep voxels as linear indices of the mask's grid), whether a
// point is near the organ's outside (where a tree leaves it), the graph's pieces (union-find),
// each node's widest branch and the organ's height.

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <vector>

#include "lamina/core/grid.h"
#include "lamina/geometry/vessel_graph.h"

namespace lamina::geometry::detail {

inline Eigen::Vector3d voxel_centre_mm(const GridFrame& f, int64_t v) {
  const int64_t i = v % f.size[0], j = (v / f.size[0]) % f.size[1], k = v / (f.size[0] * f.size[1]);
  const std::array<double, 3> p =
      f.to_physical(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k));
  return {p[0], p[1], p[2]};
}

/// Whether a voxel outside `organ` (or beyond its grid) lies within `reach_mm` of `p`.
bool near_outside(const Mask& organ, const Eigen::Vector3d& p, double reach_mm);
/// Whether a voxel inside `mask` (on its grid) lies within `reach_mm` of `p`.
bool near_inside(const Mask& mask, const Eigen::Vector3d& p, double reach_mm);

/// The connected pieces of a graph's nodes (union-find with path halving).
struct Pieces {
  std::vector<int32_t> up;
  explicit Pieces(size_t n) : up(n) { std::iota(up.begin(), up.end(), 0); }
  int32_t find(int32_t x) {
    while (up[static_cast<size_t>(x)] != x)
      x = up[static_cast<size_t>(x)] = up[static_cast<size_t>(up[static_cast<size_t>(x)])];
    return x;
  }
  void join(int32_t a, int32_t b) { up[static_cast<size_t>(find(a))] = find(b); }
};

/// Per node of `g`: the radius of the widest branch ending there (0 for a node without).
inline std::vector<double> widest_branch_at_nodes(const VesselGraph& g) {
  std::vector<double> widest(g.nodes.size(), 0.0);
  for (const VesselGraph::Branch& b : g.branches)
    for (const int32_t n : {b.a, b.b})
      widest[static_cast<size_t>(n)] = std::max(widest[static_cast<size_t>(n)], b.radius_mm);
  return widest;
}

/// The organ's lowest and highest voxel centres along physical z (superior), mm.
struct Heights {
  double lo = INFINITY, hi = -INFINITY;
  double share(double z) const { return (z - lo) / (hi - lo); }  ///< 0 at the bottom, 1 at top
};
inline Heights organ_heights(const Mask& organ) {
  Heights h;
  for (int64_t v = 0; v < organ.frame.voxel_count(); ++v)
    if (organ.inside[static_cast<size_t>(v)] != 0) {
      const double z = voxel_centre_mm(organ.frame, v).z();
      h.lo = std::min(h.lo, z);
      h.hi = std::max(h.hi, z);
    }
  return h;
}

}  // namespace lamina::geometry::detail
