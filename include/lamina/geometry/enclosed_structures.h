#pragma once
/// \file
/// Structures carved out of an organ's label (a voxel is liver *or* vessel *or* tumour, as LiTS,
/// IRCAD, the Decathlon and most 3D Slicer labelmaps store them): which of their voxels are the
/// organ's tissue, so that the organ is meshed whole and not with a tunnel where each vessel
/// runs (docs/segmentations.md, "What counts as the organ").

#include <array>
#include <cstdint>
#include <vector>

#include "lamina/core/grid.h"

namespace lamina::geometry {

/// What add_enclosed_structures() found, one entry per structure (structure s is the value
/// s + 1 in the `structures` buffer).
struct EnclosedCounts {
  std::vector<int64_t> voxels;  ///< the structure's voxels
  /// Those inside the organ: enclosed by it, taken whole (a tumour), or already in the organ's
  /// own selection (a separate mask that overlaps the organ's label, or a label also named as
  /// the organ's)
  std::vector<int64_t> inside;
  /// Those beside it: not inside, but within kBesideVoxels voxels (26-neighbour steps) of an
  /// organ voxel. A structure with no voxel inside or beside the organ is not in it at all.
  std::vector<int64_t> beside;
  int64_t organ_own = 0;  ///< the organ's own voxels that are no structure's
  int64_t added = 0;      ///< structure voxels made organ, by any rule
  /// Of `added`: by the line rule (channels, craters, a tunnel's mouths), by the ray rule only
  /// (a tunnel's length), and as part of a structure taken whole only
  int64_t by_lines = 0, by_rays = 0, by_whole = 0;
  /// The box (voxel indices, inclusive) of the organ's box and the voxels added: a tumour taken
  /// whole may reach beyond the organ's box
  std::array<int64_t, 3> added_lo{}, added_hi{};
};

/// How near to the organ a structure's voxel counts as beside it, in voxels.
inline constexpr int kBesideVoxels = 3;

/// The ray rule's bound: a structure voxel is enclosed when at most this many of the 26
/// directions from it leave without meeting the organ (a tunnel's voxel sees out along the
/// tunnel only; a vessel in a groove of the surface sees out of the groove, 5 or more).
inline constexpr int kMaxOpenRays = 4;

/// Adds to an organ's selection the structure voxels that are its tissue. A ray from a voxel in
/// one of the 26 neighbour directions, crossing structure voxels only, is blocked when it meets
/// the organ's own voxels and open otherwise. A structure voxel is organ when
/// - every one of the 13 lines through it (a direction and its opposite) is blocked on at least
///   one side (the line rule): a vessel's channel open at the hilum, a tumour's crater, a
///   tunnel's mouths, closed at the organ's own outline across the opening; or
/// - at most kMaxOpenRays of its 26 rays are open (the ray rule): a vessel passing through the
///   organ, which the line along it leaves both ways; or
/// - its structure is taken whole (`whole`, a tumour: a lesion of the organ is its tissue, also
///   where it bulges through the capsule) and its piece (26-connected) touches the organ.
/// A trunk that leaves the organ, or a vena cava lying in a groove of its surface, stays out: the
/// lines along or tangent to it and the rays out of the groove are open. Voxels of the organ's
/// own selection that are also a structure's stay organ.
/// @param[in] frame           grid of both buffers
/// @param[in,out] organ       #voxels, non-zero where the organ's own labels are; the structure
///                            voxels found organ are set to 1
/// @param[in] structures      #voxels, s + 1 where structure s lies (at most 255), 0 elsewhere
/// @param[in] structure_count number of structures
/// @param[in] whole           #structures: 1 for a structure taken whole where it touches the
///                            organ; empty: none
/// @param[in] lo, hi          the organ's bounding box, voxel indices, inclusive: no voxel
///                            outside it can be enclosed (a line along an axis would miss)
/// @return per-structure counts
/// The rules are applied in rounds, what a round takes in being organ for the next: a tunnel
/// filled along its length by the ray rule then closes its mouths by the line rule, up to the
/// organ's outline.
/// \note Each ray is followed once for all voxels (a sweep per direction over the structure
///   voxels: 26 steps a voxel), threaded over the directions; a round looks only at the voxels
///   still out; about 30 ms for 100,000 structure voxels on two cores.
EnclosedCounts add_enclosed_structures(const GridFrame& frame, std::vector<uint8_t>& organ,
                                       const std::vector<uint8_t>& structures,
                                       int32_t structure_count, const std::vector<uint8_t>& whole,
                                       const std::array<int64_t, 3>& lo,
                                       const std::array<int64_t, 3>& hi);

}  // namespace lamina::geometry
