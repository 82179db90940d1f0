#pragma once
/// \file
/// From a label volume to one clean organ mask: pick the label, crop, keep the largest
/// component, fill cavities, pad.

#include <cstdint>
#include <vector>

#include "lamina/core/grid.h"
#include "lamina/geometry/enclosed_structures.h"

namespace lamina::geometry {

/// Options for prepare_mask().
struct MaskOptions {
  int32_t label = 0;  ///< label to select; 0 = any non-zero label
  /// When not empty: the union of these labels is selected (`label` is ignored), and each must
  /// be present.
  std::vector<int32_t> labels{};
  /// Keep the largest component and fill cavities (an organ). false: every piece as it is (an
  /// embedded structure: a vessel tree in several pieces, a tumour with a necrotic core).
  bool clean = true;
  /// Structures to carry inside the organ (an embedded label, or a separate mask): #voxels of
  /// the volume's grid, s + 1 where structure s lies and 0 elsewhere; nullptr = none. The organ
  /// takes in the structure voxels it encloses (add_enclosed_structures()), so that a label map
  /// with its vessels and tumours carved out of the organ's label gives the whole organ.
  const std::vector<uint8_t>* structures = nullptr;
  int32_t structure_count = 0;  ///< structures in `structures`
  /// #structures or empty: 1 for a structure the organ takes whole where it touches it (a
  /// tumour), add_enclosed_structures()
  std::vector<uint8_t> whole_structures{};
  int pad_voxels = 1;       ///< background margin kept around the organ's bounding box, voxels
  int64_t min_voxels = 27;  ///< fewer voxels than this cannot make a meaningful surface
};

/// What prepare_mask() did, for the build report.
struct MaskReport {
  int32_t label = 0;                 ///< the label selected (0 = any non-zero)
  int64_t selected_voxels = 0;       ///< voxels carrying the label
  int32_t components = 0;            ///< face-connected components among them
  int64_t dropped_voxels = 0;        ///< voxels of the smaller components, removed
  int64_t cavity_voxels_filled = 0;  ///< internal background voxels made foreground
  bool touches_scan_border = false;  ///< the organ reached the image edge (padding closed it)
  int64_t kept_voxels = 0;           ///< voxels in the final mask
  double kept_volume_ml = 0.0;       ///< their volume, mL
  EnclosedCounts structures;         ///< with MaskOptions::structures: what the organ took in
};

/// A cleaned mask and the report of the cleaning.
struct PreparedMask {
  Mask mask;
  MaskReport report;
};

/// Selects the organ and cleans it. The result is cropped to the organ's bounding box plus
/// `pad_voxels` of background on every side, so even an organ that touches the scan edge gets a
/// closed surface.
/// @param[in] volume   the segmentation; volume.source names it in errors
/// @param[in] options  label and padding
/// \note Throws lamina::Error (kInvalidInput) when the label is absent, the mask is empty, the
///   organ has fewer than options.min_voxels voxels, or every voxel selected is a structure's.
PreparedMask prepare_mask(const LabelVolume& volume, const MaskOptions& options = {});

/// Returns `mask` with `pad` background voxels added on every side (origin moved accordingly).
Mask pad_mask(const Mask& mask, int pad);

/// The mask's boundary area, mm^2, estimated from its exposed voxel faces (beyond the grid is
/// background): a staircase over-counts a smooth surface by the mean of |nx| + |ny| + |nz| over
/// directions, 1.5, which is divided out. Sizes the skin's and the display skin's triangles.
double mask_boundary_area_mm2(const Mask& mask);

}  // namespace lamina::geometry
