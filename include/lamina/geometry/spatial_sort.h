#pragma once
/// \file
/// Vertex order for memory locality.

#include <cstdint>
#include <vector>

#include "lamina/geometry/surface_mesh.h"

namespace lamina::geometry {

/// Renumbers the vertices of `in` along a space-filling curve (meshoptimizer's spatial sort) and
/// orders the faces by their smallest vertex, into `out`. Vertices near in space end up near in
/// memory, so the simulation's passes, which read each node's neighbours, find them in cache.
/// The geometry is unchanged: same positions, same triangles, same winding.
void spatial_sort(const SurfaceMesh& in, SurfaceMesh& out);

/// The order of `points` (#P by 3) along the same space-filling curve.
/// @return #P new positions: point p goes to place order[p]
std::vector<int32_t> spatial_order(const Eigen::MatrixX3d& points);

}  // namespace lamina::geometry
