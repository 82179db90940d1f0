#pragma once
/// \file
/// The skin the viewer draws: the organ's surface at the mask's own resolution, smooth and
/// decimated to a triangle budget, beside the simulation's coarser skin (issue 33).

#include <cstdint>
#include <string>

#include "lamina/core/grid.h"
#include "lamina/geometry/surface_mesh.h"

namespace lamina::geometry {

/// The zero isosurface of the mask's signed distance (taken on the mask's own grid, not the
/// working grid the simulation's layers are meshed on), sampled on a grid of cubic cells sized
/// so that the isosurface has about `triangles` triangles (within 3%, checked and corrected;
/// at most about one per voxel-sized patch of the boundary: the mask's own resolution),
/// its largest piece, then Taubin-smoothed to take out the voxel staircase. Closed, manifold,
/// outward. Throws lamina::Error (kInvalidInput) for a budget below 100 or an empty mask.
SurfaceMesh display_skin(const Mask& mask, int64_t triangles);

/// The same for a structure carried inside the organ (a vessel tree, a tumour): every piece is
/// kept, and the cells go down to the voxel's size (three times the skin's triangles per voxel
/// of surface) so that thin vessels stay whole. `name` names the structure in errors.
SurfaceMesh structure_surface(const Mask& mask, int64_t triangles, const std::string& name);

}  // namespace lamina::geometry
