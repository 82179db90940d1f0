#pragma once
/// \file
/// Vertex order for memory locality.

#include "lamina/geometry/surface_mesh.h"

namespace lamina::geometry {

/// Renumbers the vertices of `in` along a space-filling curve (meshoptimizer's spatial sort) and
/// orders the faces by their smallest vertex, into `out`. Vertices near in space end up near in
/// memory, so the simulation's passes, which read each node's neighbours, find them in cache.
/// The geometry is unchanged: same positions, same triangles, same winding.
void spatial_sort(const SurfaceMesh& in, SurfaceMesh& out);

}  // namespace lamina::geometry
