// The territories of a model's vessel trees and its functional remnant (model_territories.h).
#include "lamina/model/model_territories.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <nanoflann.hpp>

#include "lamina/core/error.h"
#include "lamina/model/embed_surface.h"

namespace lamina::model {
namespace {

using Points = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using KdTree = nanoflann::KDTreeEigenMatrixAdaptor<Points, 3, nanoflann::metric_L2_Simple>;
using Corners = std::array<Eigen::Vector4d, 4>;  // a part's corners, barycentric

// The nearest of `seeds` to each row of `points`.
std::vector<int32_t> nearest(const Eigen::MatrixX3d& seeds, const Eigen::MatrixX3d& points) {
  const Points s = seeds;
  const KdTree tree(3, std::cref(s), 16);
  std::vector<int32_t> out(static_cast<size_t>(points.rows()), -1);
#pragma omp parallel for schedule(static) if (points.rows() > 4096)
  for (Eigen::Index v = 0; v < points.rows(); ++v) {
    const double q[3] = {points(v, 0), points(v, 1), points(v, 2)};
    Eigen::Index at = 0;
    double d2 = 0.0;
    tree.query(q, 1, &at, &d2);
    out[static_cast<size_t>(v)] = static_cast<int32_t>(at);
  }
  return out;
}

// The centroids of a part split `level` more times into eight of equal volume: its four corner
// parts and the inner octahedron's four about the diagonal between edge midpoints ab and cd.
void split(const Corners& c, int level, std::vector<Eigen::Vector4d>& out) {
  if (level == 0) {
    out.push_back((c[0] + c[1] + c[2] + c[3]) / 4.0);
    return;
  }
  const auto mid = [&](int i, int j) -> Eigen::Vector4d { return (c[i] + c[j]) / 2.0; };
  const Eigen::Vector4d ab = mid(0, 1), ac = mid(0, 2), ad = mid(0, 3), bc = mid(1, 2),
                        bd = mid(1, 3), cd = mid(2, 3);
  for (const Corners& part :
       {Corners{c[0], ab, ac, ad}, Corners{ab, c[1], bc, bd}, Corners{ac, bc, c[2], cd},
        Corners{ad, bd, cd, c[3]}, Corners{ab, cd, ac, ad}, Corners{ab, cd, ad, bd},
        Corners{ab, cd, bd, bc}, Corners{ab, cd, bc, ac}})
    split(part, level - 1, out);
}

constexpr int kMaxLevel = 1;

}  // namespace

const std::vector<Eigen::Vector4d>& sample_weights(int level) {
  static const std::array<std::vector<Eigen::Vector4d>, kMaxLevel + 1> tables = [] {
    std::array<std::vector<Eigen::Vector4d>, kMaxLevel + 1> t;
    const Corners unit{Eigen::Vector4d::Unit(0), Eigen::Vector4d::Unit(1), Eigen::Vector4d::Unit(2),
                       Eigen::Vector4d::Unit(3)};
    for (int l = 0; l <= kMaxLevel; ++l) split(unit, l, t[static_cast<size_t>(l)]);
    return t;
  }();
  return tables[static_cast<size_t>(std::clamp(level, 0, kMaxLevel))];
}

std::vector<int32_t> nearest_seeds(const ModelVesselTree& tree, const Eigen::MatrixX3d& points) {
  if (tree.seeds.V.rows() == 0) return std::vector<int32_t>(static_cast<size_t>(points.rows()), -1);
  return nearest(tree.seeds.V, points);
}

ModelTerritories model_territories(const Model& m) {
  ModelTerritories out;
  out.tets = m.tets.size();
  if (m.trees.empty() || !m.has_tets()) return out;
  const Eigen::MatrixX4i& T = m.tets.T;
  const auto n = static_cast<size_t>(T.rows());
  out.level.resize(n);
  out.first_sample.assign(n + 1, 0);
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    double longest = 0.0;
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j)
        longest = std::max(longest, (m.X.row(T(t, i)) - m.X.row(T(t, j))).norm());
    int level = 0;
    while (level < kMaxLevel && longest / std::ldexp(1.0, level) > kSampleEdgeMm) ++level;
    out.level[static_cast<size_t>(t)] = static_cast<uint8_t>(level);
    out.first_sample[static_cast<size_t>(t) + 1] =
        out.first_sample[static_cast<size_t>(t)] +
        static_cast<int64_t>(sample_weights(level).size());
  }
  const int64_t samples = out.first_sample[n];
  Eigen::MatrixX3d at(samples, 3);
  out.sample_ml.resize(static_cast<size_t>(samples));
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    const Eigen::Vector3d a = m.X.row(T(t, 0)), b = m.X.row(T(t, 1)), c = m.X.row(T(t, 2)),
                          d = m.X.row(T(t, 3));
    const std::vector<Eigen::Vector4d>& w = sample_weights(out.level[static_cast<size_t>(t)]);
    const double ml = m.tets.share_of(t) * std::abs((b - a).dot((c - a).cross(d - a))) / 6.0 /
                      1000.0 / static_cast<double>(w.size());
    int64_t s = out.first_sample[static_cast<size_t>(t)];
    for (const Eigen::Vector4d& q : w) {
      at.row(s) = (q[0] * a + q[1] * b + q[2] * c + q[3] * d).transpose();
      out.sample_ml[static_cast<size_t>(s++)] = ml;
    }
  }
  for (const ModelVesselTree& tree : m.trees) {
    out.sample_seed.push_back(nearest_seeds(tree, at));
    geometry::TreeFlow f = tree.flow;
    f.branch_territory_ml.assign(f.branches(), 0.0);
    for (size_t s = 0; s < out.sample_ml.size(); ++s) {
      const int32_t seed = out.sample_seed.back()[s];
      if (seed >= 0)
        f.branch_territory_ml[static_cast<size_t>(f.seed_branch[static_cast<size_t>(seed)])] +=
            out.sample_ml[s];
    }
    out.flows.push_back(std::move(f));
  }
  return out;
}

geometry::FunctionalRemnant functional_on_model(const Model& m, const ModelTerritories& terr,
                                                const Eigen::MatrixX3d& x,
                                                const Eigen::Vector3d& p0,
                                                const Eigen::Vector3d& normal,
                                                bool remnant_in_front, double remnant_ml) {
  if (terr.tets != m.tets.size() || terr.flows.size() != m.trees.size())
    throw invalid_input(m.source,
                        "the vessel territories were made for other tetrahedra (the model was "
                        "cut since): make them again");
  // Which samples are the remnant's where the organ is now.
  const Eigen::MatrixX4i& T = m.tets.T;
  std::vector<uint8_t> kept(static_cast<size_t>(terr.samples()), 0);
#pragma omp parallel for schedule(static) if (T.rows() > 4096)
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    // Along the normal only: each corner's height, then each sample's.
    Eigen::Vector4d h;
    for (int k = 0; k < 4; ++k) h[k] = (x.row(T(t, k)).transpose() - p0).dot(normal);
    int64_t s = terr.first_sample[static_cast<size_t>(t)];
    for (const Eigen::Vector4d& q : sample_weights(terr.level[static_cast<size_t>(t)]))
      kept[static_cast<size_t>(s++)] = (q.dot(h) > 0.0) == remnant_in_front ? 1 : 0;
  }
  std::vector<std::vector<uint8_t>> blocked(m.trees.size());
  geometry::TissueCells cells;
  cells.cell_ml = &terr.sample_ml;
  Eigen::MatrixX3d at;
  for (size_t t = 0; t < m.trees.size(); ++t) {
    const ModelVesselTree& tree = m.trees[t];
    embedded_positions(tree.seeds, x, at);
    blocked[t].assign(static_cast<size_t>(at.rows()), 0);
    for (Eigen::Index s = 0; s < at.rows(); ++s) {
      const bool front = (at.row(s).transpose() - p0).dot(normal) > 0.0;
      blocked[t][static_cast<size_t>(s)] =
          tree.in_organ[static_cast<size_t>(s)] != 0 && front != remnant_in_front ? 1 : 0;
    }
    cells.seed_of.push_back(&terr.sample_seed[t]);
  }
  std::vector<uint8_t> function;
  return geometry::functional_remnant(terr.flows, blocked, cells, kept, remnant_ml, function);
}

std::vector<int32_t> portal_sectors(const geometry::TreeFlow& flow) {
  std::vector<int32_t> out(flow.branches(), -1);
  std::vector<int32_t> path;  // b up to its root's branch
  for (size_t b = 0; b < out.size(); ++b) {
    path.clear();
    for (auto x = static_cast<int32_t>(b); x >= 0; x = flow.branch_parent[static_cast<size_t>(x)])
      path.push_back(x);
    out[b] = path[path.size() > 2 ? path.size() - 3 : 0];
  }
  return out;
}

std::vector<uint8_t> surface_function(const Model& m,
                                      const std::vector<std::vector<int32_t>>& seed_of,
                                      const geometry::FunctionalRemnant& fr,
                                      const Eigen::MatrixX3d& P, const Eigen::Vector3d& p0,
                                      const Eigen::Vector3d& normal, bool remnant_in_front) {
  const auto n = static_cast<size_t>(P.rows());
  std::vector<uint8_t> lost(n, 0), out(n, kOnResectedSide);
  std::vector<int32_t> sector(n, -1);
  for (size_t t = 0; t < m.trees.size() && t < fr.trees.size() && t < seed_of.size(); ++t) {
    const std::vector<uint8_t>& on = fr.trees[t].connected;
    const geometry::TreeFlow& flow = m.trees[t].flow;
    const bool portal = flow.kind == geometry::VesselTreeKind::kPortal;
    const std::vector<int32_t> sectors = portal ? portal_sectors(flow) : std::vector<int32_t>{};
    for (size_t v = 0; v < n && v < seed_of[t].size(); ++v) {
      const int32_t s = seed_of[t][v];
      if (s < 0 || static_cast<size_t>(s) >= on.size()) continue;
      if (on[static_cast<size_t>(s)] == 0) lost[v] |= portal ? 1 : 2;
      if (portal && sector[v] < 0)
        sector[v] = sectors[static_cast<size_t>(flow.seed_branch[static_cast<size_t>(s)])];
    }
  }
  for (size_t v = 0; v < n; ++v) {
    const double d = (P.row(static_cast<Eigen::Index>(v)).transpose() - p0).dot(normal);
    if ((d > 0.0) != remnant_in_front) continue;
    const int code = lost[v] == 1     ? kShownDevascularized
                     : lost[v] == 2   ? kShownCongested
                     : lost[v] == 3   ? kShownBoth
                     : sector[v] >= 0 ? 1 + sector[v] % 8
                                      : static_cast<int>(kFunctionalPlain);
    out[v] = static_cast<uint8_t>(code);
  }
  return out;
}

}  // namespace lamina::model
