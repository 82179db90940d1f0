#pragma once
/// \file
/// Taubin's lambda|mu smoothing: a low-pass filter on the vertex positions that removes the
/// voxel staircase of an isosurface without shrinking it (plain Laplacian smoothing would).

#include "lamina/geometry/surface_mesh.h"

namespace lamina::geometry {

/// Smooths `mesh` in place with `iterations` pairs of umbrella-Laplacian steps, a shrinking one
/// (`lambda` > 0) then an inflating one (`mu` < -lambda). Connectivity is unchanged.
/// @param[in,out] mesh        triangle mesh (any: open or closed, several pieces)
/// @param[in]     iterations  lambda|mu pairs, >= 0
/// @param[in]     lambda      0 < lambda < 1; 0.5 with mu = -0.53 passes features a few edges
///                            long and damps the one-edge wiggles (Taubin 1995)
void taubin_smooth(SurfaceMesh& mesh, int iterations, double lambda = 0.5, double mu = -0.53);

}  // namespace lamina::geometry
