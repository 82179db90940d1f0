#pragma once
/// \file
/// A world on the web page's stream (docs/web.md, "A world"): the page draws one model, so the
/// world is laid out as one whose nodes are every body's, one body after another, and whose
/// surfaces are each body's skin (its display skin if it has one, named after the body, an
/// "organ" the page's drag picks) and its structures. Every frame's positions are the bodies'
/// stacked the same way.

#include <Eigen/Core>
#include <memory>
#include <nlohmann/json.hpp>
#include <vector>

#include "lamina/model/structure_colors.h"
#include "lamina/world/world_loop.h"

namespace lamina::net::web {

struct WorldStreamModel {
  std::shared_ptr<const Model> model;  ///< nodes and embedded surfaces only: what is drawn
  std::vector<model::Rgb8> colors;     ///< per surface: each organ's, each structure's
  /// Per body, in the snapshot's order: {name, first_point, points}, the range of the stream's
  /// points (its surfaces' vertices, carried by vertices) that are that body's.
  nlohmann::json bodies = nlohmann::json::array();
};

/// The stream's model of the world in `snapshot` (its bodies' rest shapes).
WorldStreamModel world_stream_model(const world::WorldSnapshot& snapshot);

/// The bodies' positions stacked as the stream's model numbers its nodes, into `out` (resized
/// once, then reused).
void stack_positions(const world::WorldSnapshot& snapshot, Eigen::MatrixX3d& out);

}  // namespace lamina::net::web
