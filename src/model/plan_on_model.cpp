// plan_on_model (plan_on_model.h): a resection plan from the model's own surfaces.
#include "lamina/model/plan_on_model.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "lamina/core/error.h"
#include "lamina/geometry/mesh_measures.h"
#include "lamina/geometry/volume_by_plane.h"
#include "lamina/geometry/winding_number.h"
#include "lamina/model/cut_tetrahedra.h"
#include "lamina/model/embed_surface.h"
#include "lamina/model/keep_piece.h"
#include "lamina/model/model_territories.h"

namespace lamina::model {

geometry::ResectionReport plan_on_model(const Model& model, const Eigen::MatrixX3d& x,
                                        const geometry::ResectionSurface& plane,
                                        const geometry::ResectionOptions& options,
                                        const std::vector<const Eigen::MatrixX3d*>& embedded_x,
                                        const ModelTerritories* territories) {
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
  std::optional<double> keep;
  if (options.keep_point) keep = (*options.keep_point - p0).dot(n);
  geometry::fill_volumes(r, sides.front_mm3, sides.back_mm3,
                         1e-6 * (sides.front_mm3 + sides.back_mm3), keep, options, source);

  // 2. Tumours: each piece of each tumour surface.
  for (size_t s = 0; s < model.embedded.size(); ++s) {
    const EmbeddedSurface& e = model.embedded[s];
    if (e.role != SurfaceRole::kTumour) continue;
    Eigen::MatrixX3d mine;
    const Eigen::MatrixX3d& V = at(s, mine);
    // Each vertex's piece, from its triangles'.
    int pieces = 0;
    const std::vector<int> face_piece = geometry::face_components(e.F, V.rows(), pieces);
    std::vector<int32_t> piece(static_cast<size_t>(V.rows()), 0);
    for (Eigen::Index f = 0; f < e.F.rows(); ++f)
      for (int c = 0; c < 3; ++c) piece[e.F(f, c)] = face_piece[f];
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
    if (!is_anatomy(e.role)) continue;
    // Structures reach beyond the organ (a trunk leaving it): the blade covers them too.
    lo = lo.cwiseMin(e.V.colwise().minCoeff().transpose());
    hi = hi.cwiseMax(e.V.colwise().maxCoeff().transpose());
  }
  Blade blade;
  geometry::surface_triangles(plane, 0.5 * (lo + hi), 2.0 * (hi - lo).norm(), blade.V, blade.F);
  for (const StructureCut& c : structures_crossed(model, x, blade, lo, hi)) {
    if (c.role == SurfaceRole::kTumour) continue;
    if (geometry::winding_number(x, model.layers[0].F, c.position_mm) < 0.5) continue;
    r.crossings.push_back({c.name, c.role, c.label, c.position_mm, c.area_mm2, c.diameter_mm});
  }
  std::sort(r.crossings.begin(), r.crossings.end(),
            [](const auto& a, const auto& b) { return a.diameter_mm > b.diameter_mm; });

  // 4. The remnant's pieces: its tetrahedra (by their centroids) joined where they share a node.
  std::vector<uint8_t> kept;
  if (model.has_tets()) {
    const Eigen::MatrixX4i& T = model.tets.T;
    kept.assign(static_cast<size_t>(T.rows()), 0);
    for (Eigen::Index t = 0; t < T.rows(); ++t) {
      Eigen::Vector3d c = Eigen::Vector3d::Zero();
      for (int k = 0; k < 4; ++k) c += x.row(T(t, k)).transpose() / 4.0;
      kept[t] = ((c - p0).dot(n) > 0.0) == r.remnant_in_front;
    }
    const std::vector<int32_t> piece = tet_pieces(T, model.node_count(), kept);
    std::vector<geometry::RemnantPiece> pieces(static_cast<size_t>(model.node_count()));
    for (Eigen::Index t = 0; t < T.rows(); ++t) {
      if (!kept[t]) continue;
      const Eigen::Vector3d a = x.row(T(t, 0)), b = x.row(T(t, 1)), c = x.row(T(t, 2)),
                            d = x.row(T(t, 3));
      const double v = std::abs((b - a).dot((c - a).cross(d - a))) / 6.0 / 1000.0;
      geometry::RemnantPiece& p = pieces[piece[T(t, 0)]];
      p.volume_ml += v;
      p.centre_mm += v * (a + b + c + d) / 4.0;
    }
    std::vector<geometry::RemnantPiece> found;
    for (geometry::RemnantPiece& p : pieces)
      if (p.volume_ml > 0.0) {
        p.centre_mm /= p.volume_ml;
        found.push_back(p);
      }
    geometry::file_remnant_pieces(r, found);
  }

  // 5. The functional remnant: the trees the model carries, their seeds where the organ is now.
  if (model.trees.empty() || !model.has_tets()) {
    r.functional_missing =
        "the model carries no vessel trees: build it from a segmentation whose structures name "
        "the portal vein or hepatic veins (--embed LABEL=portal_vein,LABEL=hepatic_veins)";
    return r;
  }
  ModelTerritories made;
  if (territories == nullptr || territories->tets != model.tets.size()) {
    made = model_territories(model);
    territories = &made;
  }
  r.functional =
      functional_on_model(model, *territories, x, p0, n, r.remnant_in_front, r.remnant_ml);
  r.functional_flr_percent = 100.0 * r.functional->functional_ml / r.whole_ml;
  r.functional_sufficient = r.functional_flr_percent >= r.flr_threshold_percent;
  return r;
}

}  // namespace lamina::model
