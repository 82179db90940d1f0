#pragma once
/// \file
/// Several organs from one patient's segmentation (`lamina build --organ/--organ-mask`): each
/// organ a model of its own, built by build_model() on its own voxels, where the CT has it.
/// Organs come as labels of one volume or as separate masks on its grid; separate masks of
/// neighbouring organs overlap by a few hundred voxels in real data, and each contested voxel
/// goes to the organ most of its neighbours belong to (reported). A structure (--embed) stays
/// in the organ it lies in or against (most of its voxels inside or touching it).

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "lamina/core/grid.h"
#include "lamina/core/progress.h"
#include "lamina/model/build_model.h"

namespace lamina::model {

/// One organ: a label of the segmentation, or a separate mask on its grid (its non-zero voxels).
struct OrganSource {
  std::string name;
  int32_t label = 0;                          ///< > 0 with no mask
  std::shared_ptr<const LabelVolume> mask{};  ///< non-null: the organ is this mask's voxels
};

/// Voxels two organs' masks both claimed, and how many each was given.
struct OrganOverlap {
  std::string a, b;
  int64_t voxels = 0;
  int64_t to_a = 0;
};

/// One organ built.
struct OrganModel {
  std::string name;
  BuildResult built;
  int64_t voxels = 0;                   ///< its voxels after the overlaps were resolved
  std::vector<std::string> structures;  ///< the structures it holds (EmbedStructure::name)
};

/// Organs that touch in the segmentation (their voxels face to face), where a body of
/// connective tissue usually joins them.
struct OrganContact {
  std::string a, b;
  int64_t faces = 0;  ///< voxel faces between them
};

struct OrgansResult {
  std::vector<OrganModel> organs;  ///< in the order given
  std::vector<OrganOverlap> overlaps;
  std::vector<OrganContact> contacts;
};

/// Builds each organ with `options` (its label, labels and embed are set per organ): the
/// structures of options.embed each go to the organ most of whose voxels are in or against it.
/// Skin vertices: options.skin_vertices for the organ of largest surface, the others the same
/// density (at least 200), so that skins in contact are meshed alike.
/// \note Throws lamina::Error (kInvalidInput) naming the organ or the structure for fewer than
///   one organ, a name empty or given twice, a label the segmentation does not hold, a mask off
///   the segmentation's grid or empty, a structure that lies in or against no organ, and as
///   build_model() for each organ.
OrgansResult build_organs(const LabelVolume& volume, const std::vector<OrganSource>& organs,
                          const BuildOptions& options, const ProgressFn& progress = {});

}  // namespace lamina::model
