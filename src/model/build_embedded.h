#pragma once
// The build's last stage (issue 33): the display skin and the embedded structures, checked
// before any work and made after the tetrahedra. Internal to src/model.

#include "lamina/model/build_model.h"

namespace lamina::model::detail {

/// "512x512x129 voxels of 0.57x0.57x1.6 mm at (x, y, z)", for messages.
std::string describe_grid(const GridFrame& f);

/// Same voxels in space: sizes equal, spacing, origin and directions to a micrometre.
bool same_grid(const GridFrame& a, const GridFrame& b);

/// The name a structure is shown and saved by: its own, else its mask file's name without the
/// extensions, else "label N".
std::string structure_name(const EmbedStructure& s);

/// Refuses, before any work, what cannot be embedded: structures without tetrahedra, label 0 of
/// the organ's segmentation, a label that is also the organ's, a label absent from its volume, a
/// separate mask on another grid or with no voxel, two structures of one name. One-line
/// lamina::Error (kInvalidInput) naming the file and the label.
void check_embedding(const LabelVolume& volume, const BuildOptions& options);

/// The embedded structures' voxels on the segmentation's grid: s + 1 where structure s lies (its
/// label, or its separate mask's non-zero voxels; the first listed where two overlap), 0
/// elsewhere. Empty when nothing is embedded.
std::vector<uint8_t> structure_voxels(const LabelVolume& volume, const BuildOptions& options);

/// Refuses a structure with no voxel inside the organ or beside it (within
/// geometry::kBesideVoxels): a label of something else, or a mask of another organ. One line
/// naming the file, the label and the structure.
void check_structures_in_organ(const LabelVolume& volume, const BuildOptions& options,
                               const geometry::MaskReport& mask);

/// Makes the display skin from `organ` (the prepared organ mask at the segmentation's own
/// resolution) and each structure's surface, and embeds them in `m`'s rest tetrahedra; adds
/// one EmbeddedBuildInfo each to `report`. A model without tetrahedra gets no display skin.
void add_embedded(Model& m, const LabelVolume& volume, const Mask& organ,
                  const BuildOptions& options, BuildReport& report);

}  // namespace lamina::model::detail
