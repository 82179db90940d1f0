#pragma once
// Why a build failed, in terms of its input (issue 46): a mesh check that fails because the
// organ's label has tunnels where vessels were carved out of it, or because every label was
// taken as the organ, says so and what to do, instead of naming a knob that does not help.
// Internal to src/model.

#include <cstdint>
#include <string>
#include <vector>

#include "lamina/geometry/mesh_measures.h"
#include "lamina/model/build_model.h"

namespace lamina::model::detail {

/// The genus of a closed surface (its number of handles: tunnels through the solid), from its
/// Euler characteristic per component; 0 for a sphere.
int32_t surface_genus(const SurfaceMesh& mesh);

/// Labels of `volume` that are neither the organ's nor embedded, but lie inside the organ's
/// label (enclosed by it, as geometry::add_enclosed_structures decides), at least `min_share`
/// of each label's voxels: "labels 2 and 4 lie inside the organ's label 1 (3784 and 3934
/// voxel(s))", or empty. Structures carved out of the organ's label and not embedded: they leave
/// tunnels and craters in the model.
struct LabelsInside {
  std::string text;             ///< empty when none
  std::vector<int32_t> labels;  ///< the labels named
  /// "embed them (--embed 2=NAME,4=NAME) and they count as organ where it encloses them"
  std::string advice() const;
};
LabelsInside labels_inside_organ(const LabelVolume& volume, const BuildOptions& options,
                                 double min_share = 0.0);

/// The one-line message for layer `layer` failing its mesh checks (`failed`: what failed, as
/// "self-intersecting"); `mesh` is the failing layer, `skin_genus` the genus of the organ's raw
/// surface. Names the cause found in the input (tunnels and the labels that fill them, every
/// label taken as the organ, parts thinner than the skin's triangles) and what to do.
std::string explain_mesh_failure(const LabelVolume& volume, const BuildOptions& options,
                                 const BuildReport& report, int32_t layer,
                                 const std::string& failed, const SurfaceMesh& mesh,
                                 int32_t skin_genus);

}  // namespace lamina::model::detail
