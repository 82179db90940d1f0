#pragma once
// The exact Euclidean distance transform of a voxel mask (internal to src/geometry: the signed
// distance, the closing and the display skin's distance all use it, through mask_filters.h).

#include <cstdint>
#include <vector>

#include "lamina/core/grid.h"

namespace lamina::geometry::detail {

/// For every voxel outside `inside` (0), the distance in mm from its centre to the nearest centre
/// of a voxel inside it (non-zero); 0 on the voxels inside; +infinity when nothing is inside.
/// Exact, with the grid's spacing per axis: Felzenszwalb and Huttenlocher's lower envelope of
/// parabolas, one pass a line along each axis, the lines of a pass shared among the threads.
std::vector<float> distance_to_foreground(const GridFrame& frame,
                                          const std::vector<uint8_t>& inside);

/// For every voxel, the linear index of the voxel inside `inside` (non-zero) nearest to it
/// (itself when it is inside; -1 for every voxel when nothing is inside): the same transform
/// with each distance's voxel kept (a feature transform). Ties go to one of the nearest.
/// Per voxel 16 bytes while it runs: crop a large grid to the box that matters first.
std::vector<int64_t> nearest_foreground(const GridFrame& frame, const std::vector<uint8_t>& inside);

}  // namespace lamina::geometry::detail
