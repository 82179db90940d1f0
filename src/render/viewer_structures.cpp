// Registered models: copied on registration, checked at the edge (a bad array is an error naming
// the structure and what arrived, as Polyscope's validateSize does), and marked dirty when what
// their vertices show changes, so that the backend sends them once per change.
#include <fmt/format.h>

#include <cmath>

#include "lamina/core/error.h"
#include "lamina/model/embed_surface.h"
#include "lamina/render/viewer.h"
#include "viewer_state.h"

namespace lamina::render {
namespace {

Error bad(const char* what, const std::string& name, const std::string& problem) {
  return Error(ErrorKind::kInvalidInput,
               fmt::format("render::{}(\"{}\"): {}", what, name, problem));
}

// The first row of X with a NaN or an infinity, or -1.
Eigen::Index first_non_finite_row(const Eigen::MatrixX3d& X) {
  for (Eigen::Index i = 0; i < X.rows(); ++i)
    if (!X.row(i).allFinite()) return i;
  return -1;
}

void check_model(const std::string& name, const Model& m) {
  const char* what = "register_model";
  const Eigen::Index n = m.X.rows();
  if (n == 0) throw bad(what, name, "the model has no nodes (X has 0 rows)");
  if (m.layers.empty()) throw bad(what, name, "the model has no layers (no skin to draw)");
  if (const Eigen::Index i = first_non_finite_row(m.X); i >= 0)
    throw bad(what, name,
              fmt::format("rest position X row {} is not finite ({}, {}, {})", i, m.X(i, 0),
                          m.X(i, 1), m.X(i, 2)));
  for (size_t k = 0; k < m.layers.size(); ++k) {
    const Eigen::MatrixX3i& F = m.layers[k].F;
    if (F.size() > 0 && (F.minCoeff() < 0 || F.maxCoeff() >= n))
      throw bad(what, name,
                fmt::format("layer {} has a face naming node {}, outside 0..{} (X has {} rows)", k,
                            F.minCoeff() < 0 ? F.minCoeff() : F.maxCoeff(), n - 1, n));
  }
  for (size_t e = 0; e < m.springs.size(); ++e)
    if (m.springs.i[e] < 0 || m.springs.i[e] >= n || m.springs.j[e] < 0 || m.springs.j[e] >= n)
      throw bad(what, name,
                fmt::format("spring {} joins nodes {} and {}, outside 0..{}", e, m.springs.i[e],
                            m.springs.j[e], n - 1));
}

bool same_rings(const std::vector<RingHighlight>& a, const std::vector<RingHighlight>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (a[i].node != b[i].node || a[i].levels != b[i].levels) return false;
  return true;
}

bool same_looks(const std::vector<EmbeddedLook>& a, const std::vector<EmbeddedLook>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (a[i].visible != b[i].visible || a[i].color != b[i].color) return false;
  return true;
}

bool same_style(const Style& a, const Style& b) {
  return a.display_skin == b.display_skin && same_looks(a.embedded, b.embedded) &&
         a.inner == b.inner && a.skin_alpha == b.skin_alpha &&
         a.skin_wireframe == b.skin_wireframe && a.springs == b.springs &&
         a.coloring == b.coloring && a.displacement_range_mm == b.displacement_range_mm &&
         a.background == b.background && a.organ_color == b.organ_color;
}

}  // namespace

Structure& find_structure(ViewerState& s, const std::string& name, const char* what) {
  auto it = s.structures.find(name);
  if (it == s.structures.end()) {
    std::string known;
    for (const auto& [n, st] : s.structures) known += (known.empty() ? "\"" : ", \"") + n + "\"";
    throw bad(what, name,
              "no model of this name is registered" +
                  (known.empty() ? std::string(" (none is)") : " (registered: " + known + ")"));
  }
  return it->second;
}

void register_model(const std::string& name, const Model& model) {
  ViewerState& s = viewer_state("register_model");
  check_model(name, model);
  auto it = s.structures.find(name);
  const bool replaced = it != s.structures.end();
  Style style;
  if (replaced) {
    style = it->second.style;  // a replaced model keeps how it was shown
    s.backend->forget(name);
    s.structures.erase(it);
  }
  Structure st;
  st.model = std::make_unique<Model>(model);
  st.x = st.model->X;
  for (const EmbeddedSurface& e : st.model->embedded) st.embedded_x.push_back(e.V);
  st.style = replaced ? style : default_style(model);
  s.structures.emplace(name, std::move(st));
  if (!s.camera_fitted) {
    s.camera = fit_camera(model);
    s.camera_fitted = true;
  }
}

void remove_model(const std::string& name) {
  ViewerState& s = viewer_state("remove_model");
  if (s.structures.erase(name)) s.backend->forget(name);
}

bool has_model(const std::string& name) {
  return viewer_state("has_model").structures.count(name) > 0;
}

void update_positions(const std::string& name, const Eigen::MatrixX3d& x) {
  ViewerState& s = viewer_state("update_positions");
  Structure& st = find_structure(s, name, "update_positions");
  const Eigen::Index n = st.model->X.rows();
  if (x.rows() != n)
    throw bad(
        "update_positions", name,
        fmt::format("expected {} rows of positions (one per node, by 3), got {}", n, x.rows()));
  if (const Eigen::Index i = first_non_finite_row(x); i >= 0)
    throw bad(
        "update_positions", name,
        fmt::format("position row {} is not finite ({}, {}, {})", i, x(i, 0), x(i, 1), x(i, 2)));
  st.x = x;
  // The embedded surfaces follow here, once per update, into buffers of fixed size.
  for (size_t i = 0; i < st.embedded_x.size(); ++i)
    model::embedded_positions(st.model->embedded[i], st.x, st.embedded_x[i]);
  st.dirty = true;
  ++st.stats.updates;
}

const Eigen::MatrixX3d& positions(const std::string& name) {
  ViewerState& s = viewer_state("positions");
  return find_structure(s, name, "positions").x;
}

const std::vector<Eigen::MatrixX3d>& embedded_positions(const std::string& name) {
  ViewerState& s = viewer_state("embedded_positions");
  return find_structure(s, name, "embedded_positions").embedded_x;
}

const Style& style(const std::string& name) {
  ViewerState& s = viewer_state("style");
  return find_structure(s, name, "style").style;
}

void set_overlays(const std::string& name, Overlays overlays) {
  ViewerState& s = viewer_state("set_overlays");
  Structure& st = find_structure(s, name, "set_overlays");
  // Rings colour the vertices; arrows and spheres are drawn apart and cost no upload.
  if (!same_rings(st.overlays.rings, overlays.rings)) st.dirty = true;
  st.overlays = std::move(overlays);
}

void set_style(const std::string& name, const Style& style) {
  ViewerState& s = viewer_state("set_style");
  Structure& st = find_structure(s, name, "set_style");
  if (!same_style(st.style, style)) st.dirty = true;
  st.style = style;
}

StructureStats structure_stats(const std::string& name) {
  ViewerState& s = viewer_state("structure_stats");
  return find_structure(s, name, "structure_stats").stats;
}

}  // namespace lamina::render
