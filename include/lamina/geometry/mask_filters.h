#pragma once
/// \file
/// Binary-mask operations backed by ITK (kept behind plain types: see core/grid.h).

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "lamina/core/grid.h"

namespace lamina::geometry {

/// What keep_largest_component() removed.
struct ComponentStats {
  int32_t components = 0;      ///< face-connected foreground components found
  int64_t kept_voxels = 0;     ///< voxels of the largest one
  int64_t dropped_voxels = 0;  ///< voxels of all the others
};

/// Keeps only the largest face-connected (6-neighbour) foreground component.
/// @param[in,out] mask  binary mask
/// @return the component count and what was dropped
ComponentStats keep_largest_component(Mask& mask);

/// Labels the foreground's connected components 1..count (0 = background), in ITK's order
/// (first voxel met, i fastest).
/// @param[in]  mask             binary mask
/// @param[in]  fully_connected  26 neighbours (true) or face neighbours only (false)
/// @param[out] labels           #voxels component labels
/// @return the number of components
int32_t label_components(const Mask& mask, bool fully_connected, std::vector<int32_t>& labels);

/// Fills internal cavities: every background voxel not connected (6-neighbour) to the grid's
/// border becomes foreground.
/// @param[in,out] mask  binary mask; its border voxels should be background (pad it first)
/// @return the number of voxels filled
int64_t fill_cavities(Mask& mask);

/// The integer factors that box-filter a grid of `spacing_mm` to a working grid with about four
/// voxels per `edge_mm` (an edge of the mesh to come): enough to find the surface well within an
/// edge; 1 along any axis already that coarse. The model builder and the finite-element mesher
/// share it: a clinical 0.57 mm scan is meshed at 2 mm voxels, not at 9.5 million of them.
inline std::array<int, 3> working_grid_factors(const std::array<double, 3>& spacing_mm,
                                               double edge_mm) {
  std::array<int, 3> factors{};
  for (int a = 0; a < 3; ++a)
    factors[a] = std::max(1, static_cast<int>(std::floor(edge_mm / 4.0 / spacing_mm[a])));
  return factors;
}

/// Downsamples by integer factors per axis: a coarse voxel is inside when at least half of the
/// fine voxels it covers are (box-filter occupancy >= 0.5). The physical extent is kept; a
/// trailing partial block is dropped (callers pad beforehand).
/// @param[in] mask     binary mask
/// @param[in] factors  >= 1 per axis; all ones returns a copy
Mask downsample_mask(const Mask& mask, const std::array<int, 3>& factors);

/// The mask's closing by a ball of `radius_mm` (dilation, then erosion, from two exact Euclidean
/// distance transforms): every voxel that no ball of that radius around it clear of the mask can
/// reach. Fills gaps, grooves and tunnels narrower than the ball. Beyond the grid is background:
/// the result is on the mask's grid (a closing stays inside the mask's convex hull).
Mask close_mask(const Mask& mask, double radius_mm);

/// The distance (mm) of every voxel's centre to the nearest centre of a voxel of the mask (0 on
/// the mask), exact, on the mask's grid; +infinity everywhere for an empty mask.
std::vector<float> distance_to_mask(const Mask& mask);

/// Signed distance (mm) to the mask boundary, negative inside, from two exact Euclidean
/// distance transforms (ITK's Maurer filter): inside voxels measure to the nearest outside voxel
/// and vice versa.
/// \note Both sides are shifted by half a voxel (the geometric mean of the spacing) so that the
///   zero level lies on the voxel faces and the zero isosurface encloses the mask's voxel volume.
DistanceField signed_distance(const Mask& mask);

}  // namespace lamina::geometry
