#pragma once
// The build's last stage (issue 33): the display skin and the embedded structures, checked
// before any work and made after the tetrahedra. Internal to src/model.

#include "lamina/model/build_model.h"

namespace lamina::model::detail {

/// Refuses, before any work, what cannot be embedded: structures without tetrahedra, label 0 of
/// the organ's segmentation, a label that is also the organ's, a label absent from its volume, a
/// separate mask on another grid or with no voxel, two structures of one name. One-line
/// lamina::Error (kInvalidInput) naming the file and the label.
void check_embedding(const LabelVolume& volume, const BuildOptions& options);

/// Makes the display skin from `organ` (the prepared organ mask at the segmentation's own
/// resolution) and each structure's surface, and embeds them in `m`'s rest tetrahedra; adds
/// one EmbeddedBuildInfo each to `report`. A model without tetrahedra gets no display skin.
void add_embedded(Model& m, const LabelVolume& volume, const Mask& organ,
                  const BuildOptions& options, BuildReport& report);

}  // namespace lamina::model::detail
