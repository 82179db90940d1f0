#include "lamina/render/frame.h"

#include <algorithm>

#include "lamina/model/embed_surface.h"
#include "lamina/model/structure_colors.h"

namespace lamina::render {

Eigen::Vector4f ring_color(int32_t level) {
  static const float kPalette[][3] = {{1.00f, 0.92f, 0.10f}, {1.00f, 0.55f, 0.10f},
                                      {0.30f, 0.80f, 0.30f}, {0.15f, 0.70f, 0.95f},
                                      {0.35f, 0.40f, 1.00f}, {0.75f, 0.40f, 0.95f}};
  const auto& c = kPalette[static_cast<size_t>(std::max(level, 0)) % 6];
  return {c[0], c[1], c[2], 1.0f};
}

EmbeddedLook embedded_look(const Model& model, size_t index) {
  EmbeddedLook look;
  if (index >= model.embedded.size()) return look;
  const lamina::model::Rgb8 c = lamina::model::structure_colors(model)[index];
  look.color = {c[0] / 255.0f, c[1] / 255.0f, c[2] / 255.0f};
  return look;
}

Model mesh_model(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, bool two_sided) {
  Model m;
  m.X = V;
  m.mass_kg.assign(static_cast<size_t>(V.rows()), 1.0);
  m.layer_of.assign(static_cast<size_t>(V.rows()), 0);
  m.fixed.assign(static_cast<size_t>(V.rows()), 0);
  ModelLayer layer;
  layer.node_count = static_cast<int32_t>(V.rows());
  layer.F.resize((two_sided ? 2 : 1) * F.rows(), 3);
  layer.F.topRows(F.rows()) = F;
  if (two_sided) layer.F.bottomRows(F.rows()) = F.rowwise().reverse();
  m.layers.push_back(std::move(layer));
  return m;
}

Style default_style(const Model& model) {
  Style style;
  for (size_t i = 0; i < model.embedded.size(); ++i)
    style.embedded.push_back(embedded_look(model, i));
  const bool structures = model.embedded.size() >
                          (lamina::model::display_skin_index(model) >= 0 ? size_t{1} : size_t{0});
  if (structures) {
    style.skin_alpha = 0.45f;
    style.inner = InnerLayers::kHidden;
  }
  return style;
}

namespace {

const Eigen::MatrixX3d& positions(const Frame& f) {
  return f.x ? *f.x : f.model->X;
}

bool valid_node(const Frame& f, int32_t node) {
  return f.model && node >= 0 && node < positions(f).rows();
}

}  // namespace

void add_force_arrow(Frame& f, int32_t node, const Eigen::Vector3d& force_mn, double mm_per_n,
                     const Eigen::Vector4f& color) {
  if (!valid_node(f, node)) return;
  const Eigen::Vector3d at = positions(f).row(node).transpose();
  const Eigen::Vector3d centre = f.model->X.colwise().mean().transpose();
  const Eigen::Vector3d length = force_mn * (mm_per_n / 1000.0);
  Arrow a;
  a.color = color;
  if (length.dot(at - centre) < 0.0)
    a.from = at - length, a.to = at;
  else
    a.from = at, a.to = at + length;
  f.arrows.push_back(a);
}

void add_contact_marker(Frame& f, int32_t node, const Eigen::Vector4f& color) {
  if (!valid_node(f, node)) return;
  const Eigen::MatrixX3d& X = f.model->X;
  const double radius = 0.012 * (X.colwise().maxCoeff() - X.colwise().minCoeff()).norm();
  f.markers.push_back({positions(f).row(node).transpose(), radius, color});
}

}  // namespace lamina::render
