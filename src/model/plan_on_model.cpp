// plan_on_model (plan_on_model.h): a resection plan from the model's own surfaces.
#include "lamina/model/plan_on_model.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "lamina/core/error.h"
#include "lamina/geometry/volume_by_plane.h"
#include "lamina/geometry/winding_number.h"
#include "lamina/model/cut_tetrahedra.h"
#include "lamina/model/embed_surface.h"

namespace lamina::model {
namespace {

int32_t find(std::vector<int32_t>& parent, int32_t a) {
  while (parent[a] != a) a = parent[a] = parent[parent[a]];
  return a;
}

void join(std::vector<int32_t>& parent, int32_t a, int32_t b) {
  a = find(parent, a), b = find(parent, b);
  if (a != b) parent[std::max(a, b)] = std::min(a, b);
}

// Each vertex's connected piece of the triangles F (0.. in order of first vertex), and the count.
int32_t surface_pieces(const Eigen::MatrixX3i& F, Eigen::Index vertices,
                       std::vector<int32_t>& piece) {
  std::vector<int32_t> parent(static_cast<size_t>(vertices));
  std::iota(parent.begin(), parent.end(), 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    join(parent, F(f, 0), F(f, 1));
    join(parent, F(f, 0), F(f, 2));
  }
  piece.assign(static_cast<size_t>(vertices), -1);
  std::vector<int32_t> id(static_cast<size_t>(vertices), -1);
  int32_t count = 0;
  for (Eigen::Index v = 0; v < vertices; ++v) {
    const int32_t r = find(parent, static_cast<int32_t>(v));
    if (id[r] < 0) id[r] = count++;
    piece[v] = id[r];
  }
  return count;
}

}  // namespace

geometry::ResectionReport plan_on_model(const Model& model, const Eigen::MatrixX3d& x,
                                        const geometry::ResectionSurface& plane,
                                        const geometry::ResectionOptions& options,
                                        const std::vector<const Eigen::MatrixX3d*>& embedded_x) {
  const std::string& source = model.source;
  if (!plane.is_plane)
    throw invalid_input(source, "a model is planned along a plane (--plane, or a markups Plane)");
  if (x.rows() != model.node_count())
    throw invalid_input(source, "positions for " + std::to_string(x.rows()) +
                                    " nodes, the model has " + std::to_string(model.node_count()));
  const Eigen::Vector3d& n = plane.normal;
  const Eigen::Vector3d& p0 = plane.point;
  const auto at = [&](size_t s, Eigen::MatrixX3d& own) -> const Eigen::MatrixX3d& {
    if (s < embedded_x.size() && embedded_x[s] != nullptr) return *embedded_x[s];
    embedded_positions(model.embedded[s], x, own);
    return own;
  };

  geometry::ResectionReport r;
  r.input = source;
  r.liver = options.liver;
  r.margin_mm = options.margin_mm;
  // 1. Volumes.
  geometry::PlaneSides sides;
  const int32_t skin = display_skin_index(model);
  Eigen::MatrixX3d own;
  if (skin >= 0)
    sides = geometry::surface_volume_by_plane(at(static_cast<size_t>(skin), own),
                                              model.embedded[skin].F, p0, n);
  else if (model.has_tets())
    sides = geometry::volume_by_plane(x, model.tets.T, p0, n);
  else
    sides = geometry::surface_volume_by_plane(x, model.layers[0].F, p0, n);
  const double whole = sides.front_mm3 + sides.back_mm3;
  if (std::min(sides.front_mm3, sides.back_mm3) < 1e-6 * whole)
    throw invalid_input(source, "the resection surface misses the organ: all of its " +
                                    std::to_string(static_cast<int64_t>(whole / 1000.0 + 0.5)) +
                                    " mL lie on one side");
  if (options.keep_point) {
    const double s = (*options.keep_point - p0).dot(n);
    if (!std::isfinite(s) || s == 0.0)
      throw invalid_input("--keep", "the point to keep lies on the resection surface");
    r.remnant_in_front = s > 0.0;
  } else {
    r.remnant_in_front = sides.front_mm3 >= sides.back_mm3;
  }
  r.whole_ml = whole / 1000.0;
  r.remnant_ml = (r.remnant_in_front ? sides.front_mm3 : sides.back_mm3) / 1000.0;
  r.resected_ml = (r.remnant_in_front ? sides.back_mm3 : sides.front_mm3) / 1000.0;
  r.flr_percent = 100.0 * r.remnant_ml / r.whole_ml;
  r.flr_threshold_percent = geometry::flr_threshold_percent(options.liver);
  r.flr_sufficient = r.flr_percent >= r.flr_threshold_percent;

  // 2. Tumours: each piece of each tumour surface.
  for (size_t s = 0; s < model.embedded.size(); ++s) {
    const EmbeddedSurface& e = model.embedded[s];
    if (e.label == 0 || !geometry::is_tumour_name(e.name)) continue;
    Eigen::MatrixX3d mine;
    const Eigen::MatrixX3d& V = at(s, mine);
    std::vector<int32_t> piece;
    const int32_t pieces = surface_pieces(e.F, V.rows(), piece);
    struct Acc {
      int64_t front = 0, back = 0, vertices = 0;
      double least = INFINITY, volume = 0.0;
      Eigen::Vector3d centre = Eigen::Vector3d::Zero(), nearest = Eigen::Vector3d::Zero();
    };
    std::vector<Acc> acc(static_cast<size_t>(pieces));
    for (Eigen::Index v = 0; v < V.rows(); ++v) {
      Acc& a = acc[piece[v]];
      const Eigen::Vector3d q = V.row(v).transpose();
      const double d = (q - p0).dot(n);
      (d > 0.0 ? a.front : a.back) += 1;
      ++a.vertices;
      a.centre += q;
      if (std::abs(d) < a.least) {
        a.least = std::abs(d);
        a.nearest = q - d * n;
      }
    }
    for (Eigen::Index f = 0; f < e.F.rows(); ++f) {
      const Eigen::Vector3d a = V.row(e.F(f, 0)), b = V.row(e.F(f, 1)), c = V.row(e.F(f, 2));
      acc[piece[e.F(f, 0)]].volume += a.dot(b.cross(c)) / 6.0;
    }
    std::vector<size_t> order(acc.size());
    std::iota(order.begin(), order.end(), size_t{0});
    std::sort(order.begin(), order.end(),
              [&](size_t a, size_t b) { return acc[a].volume > acc[b].volume; });
    int32_t k = 0;
    for (const size_t o : order) {
      const Acc& a = acc[o];
      geometry::TumourMargin t;
      t.name = e.name;
      t.label = e.label;
      t.piece = ++k;
      t.volume_ml = std::abs(a.volume) / 1000.0;
      t.centre_mm = a.centre / static_cast<double>(a.vertices);
      t.nearest_mm = a.nearest;
      const bool divided = a.front > 0 && a.back > 0;
      t.margin_mm = divided ? 0.0 : a.least;
      t.side = divided ? "divided" : ((a.front > 0) == r.remnant_in_front ? "remnant" : "resected");
      t.clear = t.side == "resected" && t.margin_mm >= options.margin_mm;
      r.tumours.push_back(t);
    }
  }

  // 3. Crossings of the other structures, inside the organ.
  Eigen::Vector3d lo = x.colwise().minCoeff().transpose(), hi = x.colwise().maxCoeff().transpose();
  for (const EmbeddedSurface& e : model.embedded) {
    if (e.label == 0) continue;
    // Structures reach beyond the organ (a trunk leaving it): the blade covers them too.
    lo = lo.cwiseMin(e.V.colwise().minCoeff().transpose());
    hi = hi.cwiseMax(e.V.colwise().maxCoeff().transpose());
  }
  Blade blade;
  geometry::surface_triangles(plane, 0.5 * (lo + hi), 2.0 * (hi - lo).norm(), blade.V, blade.F);
  for (const StructureCut& c : structures_crossed(model, x, blade, lo, hi)) {
    if (geometry::is_tumour_name(c.name)) continue;
    if (geometry::winding_number(x, model.layers[0].F, c.position_mm) < 0.5) continue;
    r.crossings.push_back({c.name, c.label, c.position_mm, c.area_mm2, c.diameter_mm});
  }
  std::sort(r.crossings.begin(), r.crossings.end(),
            [](const auto& a, const auto& b) { return a.diameter_mm > b.diameter_mm; });

  // 4. The remnant's pieces: its tetrahedra joined where they share a node.
  if (model.has_tets()) {
    const Eigen::MatrixX4i& T = model.tets.T;
    std::vector<int32_t> parent(static_cast<size_t>(model.node_count()));
    std::iota(parent.begin(), parent.end(), 0);
    std::vector<uint8_t> kept(static_cast<size_t>(T.rows()), 0);
    for (Eigen::Index t = 0; t < T.rows(); ++t) {
      Eigen::Vector3d c = Eigen::Vector3d::Zero();
      for (int k = 0; k < 4; ++k) c += x.row(T(t, k)).transpose() / 4.0;
      kept[t] = ((c - p0).dot(n) > 0.0) == r.remnant_in_front;
      if (kept[t])
        for (int k = 1; k < 4; ++k) join(parent, T(t, 0), T(t, k));
    }
    std::vector<geometry::RemnantPiece> pieces(static_cast<size_t>(model.node_count()));
    for (Eigen::Index t = 0; t < T.rows(); ++t) {
      if (!kept[t]) continue;
      const Eigen::Vector3d a = x.row(T(t, 0)), b = x.row(T(t, 1)), c = x.row(T(t, 2)),
                            d = x.row(T(t, 3));
      const double v = std::abs((b - a).dot((c - a).cross(d - a))) / 6.0 / 1000.0;
      geometry::RemnantPiece& p = pieces[find(parent, T(t, 0))];
      p.volume_ml += v;
      p.centre_mm += v * (a + b + c + d) / 4.0;
    }
    for (geometry::RemnantPiece& p : pieces) {
      if (p.volume_ml <= 0.0) continue;
      p.centre_mm /= p.volume_ml;
      if (p.volume_ml >= geometry::kMinPieceMl)
        r.remnant_pieces.push_back(p);
      else
        r.remnant_fragments_ml += p.volume_ml;
    }
    std::sort(r.remnant_pieces.begin(), r.remnant_pieces.end(),
              [](const auto& a, const auto& b) { return a.volume_ml > b.volume_ml; });
  }
  return r;
}

}  // namespace lamina::model
