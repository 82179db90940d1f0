#pragma once
/// \file
/// Fills a model's layers with tetrahedra: the volume between the surfaces.

#include "lamina/geometry/measure_tets.h"
#include "lamina/geometry/tetrahedralize_shells.h"
#include "lamina/model/model.h"

namespace lamina::model {

/// Fills the shells between neighbouring layers and the core inside the deepest layer with
/// tetrahedra whose boundary faces are exactly the layers' triangles
/// (geometry::tetrahedralize_shells), and makes them the model's volume.
/// @param[in]     options  tetrahedral mesh quality bounds
/// @param[in,out] model    in: nodes, layers (X, layer_of, layers) and density; out: the interior
///                         nodes the mesher added appended (kInteriorNode, in space-filling-curve
///                         order), `tets`, `springs` = every tetrahedron edge once (kIntraLayer
///                         for a layer's triangle edge, kVolume for the others; stiffness 0, for
///                         the caller to set), `mass_kg` = density x a quarter of each incident
///                         tetrahedron's volume, `fixed` resized
/// @return the tetrahedra's quality at rest
/// \note Throws lamina::Error (kInternal) if the layers cannot be meshed conformingly.
geometry::TetQuality fill_tetrahedra(const geometry::TetOptions& options, Model& model);

}  // namespace lamina::model
