// A world laid out as one model for the web page's stream (world_stream.h).
#include "world_stream.h"

#include "lamina/model/embed_surface.h"

namespace lamina::net::web {
namespace {

// A body's surface in the stream's model: its vertices carried by the body's nodes, which sit
// `offset` rows down in the stacked positions.
EmbeddedSurface moved_down(EmbeddedSurface e, int32_t offset) {
  e.corners.array() += offset;
  return e;
}

// A body without embedded surfaces: its skin (layer 0), each vertex carried by its own node.
EmbeddedSurface skin_surface(const Model& m, int32_t offset) {
  const ModelLayer& skin = m.layers[0];
  EmbeddedSurface e;
  e.V = m.X.middleRows(skin.first_node, skin.node_count);
  e.F = skin.F.array() - skin.first_node;
  e.corners.resize(skin.node_count, 4);
  e.weights = Eigen::MatrixX4d::Zero(skin.node_count, 4);
  for (int32_t v = 0; v < skin.node_count; ++v) {
    e.corners.row(v).setConstant(offset + skin.first_node + v);
    e.weights(v, 0) = 1.0;
  }
  return e;
}

}  // namespace

WorldStreamModel world_stream_model(const world::WorldSnapshot& snapshot) {
  auto m = std::make_shared<Model>();
  WorldStreamModel out;
  int32_t nodes = 0;
  for (const world::BodyView& b : snapshot.bodies) nodes += b.model->node_count();
  m->X.resize(nodes, 3);
  int32_t offset = 0, points = 0;
  for (size_t k = 0; k < snapshot.bodies.size(); ++k) {
    const world::BodyView& b = snapshot.bodies[k];
    const Model& bm = *b.model;
    m->X.middleRows(offset, bm.node_count()) = bm.X;
    const int32_t first_point = points;
    const model::Rgb8 organ = model::organ_color(b.name, k);
    const auto add = [&](EmbeddedSurface e, model::Rgb8 color) {
      points += static_cast<int32_t>(e.V.rows());
      m->embedded.push_back(std::move(e));
      out.colors.push_back(color);
    };
    if (bm.embedded.empty()) {
      EmbeddedSurface skin = skin_surface(bm, offset);
      skin.name = b.name;
      skin.role = SurfaceRole::kDisplaySkin;
      add(std::move(skin), organ);
    } else {
      const std::vector<model::Rgb8> own = model::structure_colors(bm);
      for (size_t e = 0; e < bm.embedded.size(); ++e) {
        EmbeddedSurface s = moved_down(bm.embedded[e], offset);
        const bool skin = s.role == SurfaceRole::kDisplaySkin;
        if (skin) s.name = b.name;
        add(std::move(s), skin ? organ : own[e]);
      }
    }
    out.bodies.push_back(
        {{"name", b.name}, {"first_point", first_point}, {"points", points - first_point}});
    offset += bm.node_count();
  }
  out.model = std::move(m);
  return out;
}

void stack_positions(const world::WorldSnapshot& snapshot, Eigen::MatrixX3d& out) {
  Eigen::Index rows = 0;
  for (const world::BodyView& b : snapshot.bodies) rows += b.x.rows();
  if (out.rows() != rows) out.resize(rows, 3);
  Eigen::Index at = 0;
  for (const world::BodyView& b : snapshot.bodies) {
    out.middleRows(at, b.x.rows()) = b.x;
    at += b.x.rows();
  }
}

}  // namespace lamina::net::web
