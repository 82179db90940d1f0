#pragma once
/// \file
/// The curve skeleton of a binary mask (a vessel tree's centrelines, voxel by voxel): the mask
/// thinned to curves one voxel wide that keep its topology (its components, tunnels and
/// cavities) and lie along its middle, with each skeleton voxel's distance to the background
/// (the vessel's radius there). The first stage of the vessel trees (issue 63).

#include <cstdint>
#include <vector>

#include "lamina/core/grid.h"

namespace lamina::geometry {

/// A skeleton of a mask, on the mask's grid.
struct Skeleton {
  GridFrame frame;               ///< the mask's
  std::vector<int64_t> voxels;   ///< linear indices of the skeleton's voxels, ascending
  std::vector<float> radius_mm;  ///< per skeleton voxel: distance from its centre to the
                                 ///< nearest background voxel's centre, mm
  int32_t passes = 0;            ///< thinning passes made (each peels about one voxel layer)
};

/// Thins `mask` to its curve skeleton: distance-ordered homotopic thinning (Pudney 1998). Each
/// pass visits the border voxels nearest the background first and removes one when it is a
/// simple point (Bertrand and Malandain's topological numbers: one 26-connected foreground
/// component and one 6-connected background component in its neighbourhood, so that removing
/// it changes no component, tunnel or cavity) and not the end of a curve (one neighbour), until
/// a pass removes nothing. Works on the mask's bounding box only.
/// @param[in] mask  binary mask (a vessel segmentation); an empty one gives an empty skeleton
/// @return the skeleton; 26-connected within each of the mask's 26-connected components
Skeleton skeletonize(const Mask& mask);

/// Whether the centre of a 3 x 3 x 3 neighbourhood is a simple point of its foreground (26/6
/// connectivity): bit (dx + 1) + 3 (dy + 1) + 9 (dz + 1) of `cube` is voxel (dx, dy, dz), the
/// centre (bit 13) ignored. Exposed for its test.
bool is_simple_point(uint32_t cube);

}  // namespace lamina::geometry
