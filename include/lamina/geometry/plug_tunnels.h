#pragma once
/// \file
/// Tunnels through an organ too narrow for its model: plugged, and nothing else changed.

#include <cstdint>
#include <vector>

#include "lamina/core/grid.h"

namespace lamina::geometry {

/// What plug_tunnels() did.
struct TunnelPlugs {
  int32_t tunnels_before = 0;  ///< tunnels through the mask (1 - its Euler characteristic)
  int32_t tunnels_after = 0;   ///< those left: wider than the ball
  int32_t plugs = 0;           ///< pieces of background made organ
  double radius_mm = 0.0;      ///< the largest ball that plugged one (0: none)
  int64_t voxels = 0;          ///< voxels made organ, the plugs and the corners
  int64_t corner_voxels = 0;   ///< of them, those that made it well-composed
  double volume_ml = 0.0;      ///< the voxels' volume
};

/// The Euler characteristic of a binary mask's solid: components - tunnels + cavities (1 for a
/// ball, 0 for a ring), of its voxels joined by faces, or with `corners` by edges and corners
/// too (the union of the closed voxel cubes).
int64_t euler_characteristic(const Mask& mask, bool corners = false);

/// Adds voxels until no two voxels, and no two background voxels, touch by an edge or a corner
/// alone (the mask is well-composed): then joining voxels by faces, by corners, or as an
/// isosurface does, all give the same topology. Returns the voxels added (their count).
int64_t make_well_composed(Mask& mask);

/// Plugs the tunnels through `mask` narrower than a ball of `radius_mm`: for balls growing from a
/// voxel and a half to `radius_mm`, of the background voxels the mask's closing by the ball adds
/// (close_mask()), each 26-connected piece is made organ only when that raises the mask's Euler
/// characteristic (it closes a tunnel); a piece that fills a groove, a fissure or a dent changes
/// no topology and is left out. So an organ without tunnels is returned as it was, a tunnel is
/// plugged by the smallest ball that closes it, and a tunnel wider than the largest stays (the
/// model keeps it). With `corners`, the mask is made well-composed first (make_well_composed():
/// voxels touching by an edge or a corner alone, which an isosurface may join into a tunnel that
/// face-connected voxels do not have), and its tunnels through corners are plugged too.
/// @param[in,out] mask       a single-component mask without cavities (prepare_mask())
/// @param[in]     radius_mm  the largest ball's radius, mm, > 0
/// @param[out]    added      optional: #voxels of the mask's grid, 1 where a voxel was added
/// @param[in]     corners    also the tunnels through corners (see above)
/// @return what was plugged and the tunnels before and after
TunnelPlugs plug_tunnels(Mask& mask, double radius_mm, std::vector<uint8_t>* added = nullptr,
                         bool corners = false);

}  // namespace lamina::geometry
