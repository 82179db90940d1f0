#pragma once
/// \file
/// Surfaces carried by the tetrahedra (SOFA's BarycentricMapping, iMSTK's tetrahedra-to-triangles
/// map): a fine display skin, vessels and tumours inside the organ, deformed with it.

#include <Eigen/Core>
#include <string>

#include "lamina/model/model.h"

namespace lamina::model {

/// The surface (V, F) at rest, embedded in the model's rest tetrahedra: each vertex's tetrahedron
/// and barycentric weights; a vertex in no tetrahedron takes, among those around its nearest
/// centroid, the one it is least outside of (largest smallest weight: the mildest
/// extrapolation), counted in EmbeddedSurface::outside. Where those weights' sizes would sum to
/// more than kMaxAmplification, the vertex takes an offset instead (EmbeddedSurface::offsets).
/// Throws lamina::Error (kInvalidInput) naming
/// `name` when the model has no tetrahedra, the surface is empty, a triangle indexes no vertex or a
/// vertex is not finite.
EmbeddedSurface embed_surface(const Model& model, const Eigen::MatrixX3d& V,
                              const Eigen::MatrixX3i& F, const std::string& name, SurfaceRole role,
                              int32_t label = 0);

/// Points embedded as embed_surface() embeds a surface's vertices, without triangles: a vessel
/// tree's seeds (ModelVesselTree::seeds). Throws as embed_surface() does ("there are no points to
/// embed" for none).
EmbeddedSurface embed_points(const Model& model, const Eigen::MatrixX3d& V, const std::string& name,
                             SurfaceRole role, int32_t label = 0);
/// The name `lamina build` gives the display skin it embeds.
inline constexpr const char* kDisplaySkinName = "display_skin";

/// The index of the model's display skin (the first embedded surface of role
/// SurfaceRole::kDisplaySkin) in Model::embedded, or -1.
int32_t display_skin_index(const Model& model);

/// The largest sum of |weights| over the surface's vertices: no vertex moves more than this many
/// times the largest motion of its tetrahedron's nodes (at most kMaxAmplification).
double max_amplification(const EmbeddedSurface& surface);

/// The vertices that follow their tetrahedron by a rest offset (non-zero rows of offsets).
int32_t offset_vertices(const EmbeddedSurface& surface);

/// The embedded surface's vertices at node positions x: out = W x + offsets, four weights a row.
/// Threaded over the vertices; `out` is resized only when its size differs (no allocation frame to
/// frame).
void embedded_positions(const EmbeddedSurface& surface, const Eigen::MatrixX3d& x,
                        Eigen::MatrixX3d& out);

}  // namespace lamina::model
