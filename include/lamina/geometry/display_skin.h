#pragma once
/// \file
/// The skin the viewer draws: the organ's surface at the mask's own resolution, smooth and
/// decimated to a triangle budget, beside the simulation's coarser skin (issue 33).

#include <cstdint>

#include "lamina/core/grid.h"
#include "lamina/geometry/surface_mesh.h"

namespace lamina::geometry {

/// The zero isosurface of the mask's signed distance on its own grid (not the working grid the
/// simulation's layers are meshed on), its largest piece, remeshed (CGAL isotropic remeshing)
/// to about `triangles` near-equilateral triangles: closed, manifold, outward. Throws
/// lamina::Error (kInvalidInput) for a budget below 100 or an empty mask.
SurfaceMesh display_skin(const Mask& mask, int64_t triangles);

}  // namespace lamina::geometry
