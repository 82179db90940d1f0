#pragma once
/// \file
/// Resection planning on a model (`lamina resect MODEL.vtu`, the viewer's resection plane): the
/// same report as geometry::plan_resection's, from the model's own surfaces at any shape.

#include <Eigen/Core>
#include <vector>

#include "lamina/geometry/plan_resection.h"
#include "lamina/model/model.h"
#include "lamina/model/model_territories.h"

namespace lamina::model {

/// Plans a resection of the model at positions x along a plane.
/// - Volumes: the display skin's (the organ at its segmentation's resolution) on each side, each
///   triangle clipped exactly (geometry::surface_volume_by_plane); without one, the tetrahedra's
///   (geometry::volume_by_plane).
/// - Tumours: every embedded surface whose name says tumour (geometry::is_tumour_name), each of
///   its connected pieces: its side, and its margin, the least distance of its vertices to the
///   plane (0 when the plane divides it).
/// - Crossings: every other structure's sections by the plane inside the organ
///   (model::structures_crossed, kept where the skin's winding number says inside).
/// - Remnant pieces: the tetrahedra on the remnant's side (by their centroids), joined where they
///   share a node.
/// - The functional remnant (issue 63), when the model carries vessel trees (Model::trees): the
///   seeds in the organ on the resected side taken, the tissue on the remnant's side whose
///   nearest seed no longer reaches its root lost (model::functional_on_model); without trees,
///   functional_missing says why.
/// Of `options`, keep_point, margin_mm and liver are used (the structures are the model's own).
/// @param[in] embedded_x  each embedded surface's positions at x (Frame::embedded_x's
///                        convention), or empty to compute them here
/// @param[in] territories  model_territories(model), kept by a caller that plans again and
///                         again (the viewer); null, or made for other tetrahedra: made here
/// \note Throws lamina::Error (kInvalidInput): a surface that is not a plane ("a model is planned
///   along a plane"), a plane that misses the organ, a point to keep on the plane, x of the wrong
///   size.
geometry::ResectionReport plan_on_model(const Model& model, const Eigen::MatrixX3d& x,
                                        const geometry::ResectionSurface& plane,
                                        const geometry::ResectionOptions& options,
                                        const std::vector<const Eigen::MatrixX3d*>& embedded_x = {},
                                        const ModelTerritories* territories = nullptr);

}  // namespace lamina::model
