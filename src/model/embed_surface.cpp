// A surface embedded in the rest tetrahedra. Each vertex is located by a uniform grid over the
// tetrahedra's bounding boxes (about four tetrahedra a cell): a query looks at its cell's few
// tetrahedra and solves each one's 3x3 barycentric system. Written here rather than with CGAL's
// AABB tree, which has no tetrahedron primitive and no point-location query over one; the grid is
// a few dozen lines, built once per surface, and linear in the tetrahedra (docs/architecture.md).
#include "lamina/model/embed_surface.h"

#include <omp.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "lamina/core/error.h"
#include "lamina/geometry/closest_on_triangle.h"

namespace lamina::model {
namespace {

// Tetrahedra by the grid cells their bounding boxes overlap (CSR).
struct TetGrid {
  Eigen::Vector3d lo;
  double cell = 1.0;
  Eigen::Vector3i n;
  std::vector<int32_t> offsets, tets;
  // Per tetrahedron: its first corner and the inverse of its edge matrix, so that a point's
  // barycentric weights are one 3x3 product (a point outside tries dozens of tetrahedra).
  std::vector<Eigen::Vector3d> origin;
  std::vector<Eigen::Matrix3d> inverse;
  std::vector<Eigen::Vector3d> centroid;  // for the nearest-centroid search of outside points

  Eigen::Vector3i cell_of(const Eigen::Vector3d& p) const {
    Eigen::Vector3i c;
    for (int d = 0; d < 3; ++d)
      c[d] = std::clamp(static_cast<int>(std::floor((p[d] - lo[d]) / cell)), 0, n[d] - 1);
    return c;
  }
  int64_t index(const Eigen::Vector3i& c) const {
    return (static_cast<int64_t>(c[2]) * n[1] + c[1]) * n[0] + c[0];
  }
};

TetGrid make_grid(const Model& m) {
  const Eigen::Index nt = m.tets.size();
  TetGrid g;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (Eigen::Index t = 0; t < nt; ++t)
    for (int c = 0; c < 4; ++c) {
      lo = lo.cwiseMin(m.X.row(m.tets.T(t, c)).transpose());
      hi = hi.cwiseMax(m.X.row(m.tets.T(t, c)).transpose());
    }
  const Eigen::Vector3d size = (hi - lo).cwiseMax(1e-9);
  g.cell = std::cbrt(size.prod() * 4.0 / static_cast<double>(nt));
  g.lo = lo;
  for (int d = 0; d < 3; ++d)
    g.n[d] = std::clamp(static_cast<int>(std::ceil(size[d] / g.cell)), 1, 1024);
  const int64_t cells = static_cast<int64_t>(g.n[0]) * g.n[1] * g.n[2];
  const auto each_cell = [&](Eigen::Index t, auto&& visit) {
    Eigen::Vector3d a = m.X.row(m.tets.T(t, 0)).transpose(), b = a;
    for (int c = 1; c < 4; ++c) {
      a = a.cwiseMin(m.X.row(m.tets.T(t, c)).transpose());
      b = b.cwiseMax(m.X.row(m.tets.T(t, c)).transpose());
    }
    const Eigen::Vector3i from = g.cell_of(a), to = g.cell_of(b);
    for (int z = from[2]; z <= to[2]; ++z)
      for (int y = from[1]; y <= to[1]; ++y)
        for (int x = from[0]; x <= to[0]; ++x) visit(g.index(Eigen::Vector3i(x, y, z)));
  };
  g.offsets.assign(static_cast<size_t>(cells) + 1, 0);
  for (Eigen::Index t = 0; t < nt; ++t) each_cell(t, [&](int64_t k) { ++g.offsets[k + 1]; });
  for (int64_t k = 0; k < cells; ++k) g.offsets[k + 1] += g.offsets[k];
  g.tets.resize(static_cast<size_t>(g.offsets[cells]));
  std::vector<int32_t> fill(g.offsets.begin(), g.offsets.end() - 1);
  for (Eigen::Index t = 0; t < nt; ++t)
    each_cell(t, [&](int64_t k) { g.tets[fill[k]++] = static_cast<int32_t>(t); });
  g.origin.resize(static_cast<size_t>(nt));
  g.inverse.resize(static_cast<size_t>(nt));
  g.centroid.resize(static_cast<size_t>(nt));
  for (Eigen::Index t = 0; t < nt; ++t) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) c += m.X.row(m.tets.T(t, k)).transpose();
    g.centroid[static_cast<size_t>(t)] = 0.25 * c;
    const Eigen::Vector3d a = m.X.row(m.tets.T(t, 0)).transpose();
    Eigen::Matrix3d D;
    for (int c = 1; c < 4; ++c) D.col(c - 1) = m.X.row(m.tets.T(t, c)).transpose() - a;
    g.origin[static_cast<size_t>(t)] = a;
    g.inverse[static_cast<size_t>(t)] = D.inverse();
  }
  return g;
}

// Barycentric weights of p in tetrahedron t at rest.
Eigen::Vector4d barycentric(const TetGrid& g, int32_t t, const Eigen::Vector3d& p) {
  const Eigen::Vector3d l =
      g.inverse[static_cast<size_t>(t)] * (p - g.origin[static_cast<size_t>(t)]);
  return Eigen::Vector4d(1.0 - l.sum(), l[0], l[1], l[2]);
}

// The tetrahedron containing p (its weights all >= -1e-9), or -1.
int32_t containing(const TetGrid& g, const Eigen::Vector3d& p, Eigen::Vector4d& w) {
  const int64_t k = g.index(g.cell_of(p));
  for (int32_t q = g.offsets[k]; q < g.offsets[k + 1]; ++q) {
    w = barycentric(g, g.tets[q], p);
    if (w.minCoeff() >= -1e-9) return g.tets[q];
  }
  return -1;
}

// The tetrahedron whose centroid is nearest to p: the grid's cells in growing shells around p's
// cell, until a shell can hold nothing nearer than the best found.
int32_t nearest(const TetGrid& g, const Eigen::Vector3d& p) {
  const Eigen::Vector3i at = g.cell_of(p);
  const Eigen::Vector3d clamped = p.cwiseMax(g.lo).cwiseMin(g.lo + g.cell * g.n.cast<double>());
  const double outside = (p - clamped).norm();  // p beyond the grid's box
  int32_t best = -1;
  double best_d = std::numeric_limits<double>::infinity();
  const int most = g.n.maxCoeff();
  for (int r = 0; r <= most; ++r) {
    const double reach = outside + (r - 1) * g.cell;  // nearest a shell's cells can be
    if (best >= 0 && reach > 0.0 && reach * reach > best_d) break;
    for (int z = at[2] - r; z <= at[2] + r; ++z)
      for (int y = at[1] - r; y <= at[1] + r; ++y)
        for (int x = at[0] - r; x <= at[0] + r; ++x) {
          if (std::max({std::abs(x - at[0]), std::abs(y - at[1]), std::abs(z - at[2])}) != r)
            continue;  // the shell only
          if (x < 0 || y < 0 || z < 0 || x >= g.n[0] || y >= g.n[1] || z >= g.n[2]) continue;
          const int64_t k = g.index(Eigen::Vector3i(x, y, z));
          for (int32_t q = g.offsets[k]; q < g.offsets[k + 1]; ++q) {
            const double d = (g.centroid[static_cast<size_t>(g.tets[q])] - p).squaredNorm();
            if (d < best_d) best_d = d, best = g.tets[q];
          }
        }
  }
  return best;
}

// For a point in no tetrahedron: among the tetrahedra around its nearest centroid (those in the
// grid cells next to that centroid's), the one it is least outside of, whose smallest barycentric
// weight is largest (the centroid-nearest one on a tie). Its weights extrapolate least: a point
// just outside the coarse skin's flat face takes that face's tetrahedron, not a thin neighbour
// whose weights would reach -1.5, and the surface follows that tetrahedron's motion without
// amplifying it (the largest sum of |weights| on the phantom's display skin: 6.1 by the nearest
// centroid alone, 2.0 this way).
// `seen` (one entry per tetrahedron, the caller's: no allocation per point) skips a tetrahedron
// the neighbouring cells list again: each lies in several cells, and its weights were most of the
// build's time under ASan.
int32_t least_outside(const TetGrid& g, const Eigen::Vector3d& p, std::vector<int32_t>& seen,
                      int32_t stamp, Eigen::Vector4d& w) {
  const int32_t first = nearest(g, p);
  w = barycentric(g, first, p);
  seen[static_cast<size_t>(first)] = stamp;
  int32_t best = first;
  double best_min = w.minCoeff();
  const Eigen::Vector3i at = g.cell_of(g.centroid[static_cast<size_t>(first)]);
  const Eigen::Vector3i from = (at.array() - 1).max(0), to = (at.array() + 1).min(g.n.array() - 1);
  for (int z = from[2]; z <= to[2]; ++z)
    for (int y = from[1]; y <= to[1]; ++y)
      for (int x = from[0]; x <= to[0]; ++x) {
        const int64_t k = g.index(Eigen::Vector3i(x, y, z));
        for (int32_t q = g.offsets[k]; q < g.offsets[k + 1]; ++q) {
          if (std::exchange(seen[static_cast<size_t>(g.tets[q])], stamp) == stamp) continue;
          const Eigen::Vector4d wq = barycentric(g, g.tets[q], p);
          if (wq.minCoeff() > best_min) best_min = wq.minCoeff(), best = g.tets[q], w = wq;
        }
      }
  return best;
}

// The sum of |weights| of w0 + s (w1 - w0): how much a vertex with those weights can amplify its
// tetrahedron's motion.
double amplification(const Eigen::Vector4d& w0, const Eigen::Vector4d& w1, double s) {
  return (w0 + s * (w1 - w0)).cwiseAbs().sum();
}

// A vertex at p, outside tetrahedron t with weights w (summing to 1) whose sizes sum to more than
// kMaxAmplification: the weights of the point q + s (p - q), q the tetrahedron's point nearest p,
// with s the largest in [0, 1] that keeps the sum at kMaxAmplification (it is 1 at q, where all
// weights are >= 0, and convex in s, so one crossing), and the offset (1 - s) (p - q) that puts
// the vertex back at p. Its motion is then that point's: a translation of the vertex by at most
// kMaxAmplification times its tetrahedron's largest node motion.
Eigen::Vector3d limit_amplification(const Model& m, int32_t t, const Eigen::Vector3d& p,
                                    Eigen::Vector4d& w) {
  // The nearest point on the tetrahedron's faces (p is outside it), as weights of its corners.
  static constexpr int kFaces[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
  Eigen::Vector3d corner[4];
  for (int c = 0; c < 4; ++c) corner[c] = m.X.row(m.tets.T(t, c)).transpose();
  Eigen::Vector4d wq = Eigen::Vector4d::Zero();
  double best = std::numeric_limits<double>::infinity();
  for (const auto& f : kFaces) {
    const Eigen::Vector3d b =
        geometry::closest_on_triangle(p, corner[f[0]], corner[f[1]], corner[f[2]]);
    const Eigen::Vector3d q = b[0] * corner[f[0]] + b[1] * corner[f[1]] + b[2] * corner[f[2]];
    if ((q - p).squaredNorm() < best) {
      best = (q - p).squaredNorm();
      wq.setZero();
      for (int k = 0; k < 3; ++k) wq[f[k]] = b[k];
    }
  }
  // A hair under the bound, so that the rounding of the weights below cannot take it over.
  const double bound = kMaxAmplification * (1.0 - 1e-12);
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (amplification(wq, w, mid) <= bound ? lo : hi) = mid;
  }
  const Eigen::Vector4d ws = wq + lo * (w - wq);
  Eigen::Vector3d q = Eigen::Vector3d::Zero();
  for (int c = 0; c < 4; ++c) q += ws[c] * corner[c];
  w = ws;
  return p - q;
}

}  // namespace

EmbeddedSurface embed_surface(const Model& m, const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                              const std::string& name, SurfaceRole role, int32_t label) {
  if (V.rows() == 0 || F.rows() == 0) throw invalid_input(name, "the surface is empty");
  if (F.minCoeff() < 0 || F.maxCoeff() >= V.rows())
    throw invalid_input(name, "a triangle names a vertex the surface does not have");
  EmbeddedSurface s = embed_points(m, V, name, role, label);
  s.F = F;
  return s;
}

EmbeddedSurface embed_points(const Model& m, const Eigen::MatrixX3d& V, const std::string& name,
                             SurfaceRole role, int32_t label) {
  if (!m.has_tets())
    throw invalid_input(name, "the model has no tetrahedra to carry it (build with tetrahedra)");
  if (V.rows() == 0) throw invalid_input(name, "there are no points to embed");
  if (!V.allFinite()) throw invalid_input(name, "a vertex is not finite");
  EmbeddedSurface s;
  s.name = name, s.role = role, s.label = label, s.V = V;
  s.F.resize(0, 3);
  s.corners.resize(V.rows(), 4);
  s.weights.resize(V.rows(), 4);
  const TetGrid g = make_grid(m);
  Eigen::MatrixX3d offsets = Eigen::MatrixX3d::Zero(V.rows(), 3);
  int32_t outside = 0, offset = 0;
#pragma omp parallel reduction(+ : outside, offset)
  {
    std::vector<int32_t> seen(static_cast<size_t>(m.tets.size()), -1);
#pragma omp for schedule(dynamic, 256)
    for (Eigen::Index v = 0; v < V.rows(); ++v) {
      const Eigen::Vector3d p = V.row(v).transpose();
      Eigen::Vector4d w;
      int32_t t = containing(g, p, w);
      if (t < 0) {
        t = least_outside(g, p, seen, static_cast<int32_t>(v), w);
        ++outside;
        if (w.cwiseAbs().sum() > kMaxAmplification) {
          offsets.row(v) = limit_amplification(m, t, p, w).transpose();
          ++offset;
        }
      }
      s.corners.row(v) = m.tets.T.row(t);
      s.weights.row(v) = w.transpose();
    }
  }
  s.outside = outside;
  if (offset > 0) s.offsets = std::move(offsets);
  return s;
}

void embedded_positions(const EmbeddedSurface& s, const Eigen::MatrixX3d& x,
                        Eigen::MatrixX3d& out) {
  const Eigen::Index n = s.weights.rows();
  if (out.rows() != n) out.resize(n, 3);
  const int* c = s.corners.data();     // column-major: corner k of vertex v at [k n + v]
  const double* w = s.weights.data();  // the same
  const double *x0 = x.col(0).data(), *x1 = x.col(1).data(), *x2 = x.col(2).data();
  double *o0 = out.col(0).data(), *o1 = out.col(1).data(), *o2 = out.col(2).data();
  // Below a few thousand vertices a parallel region costs more than it saves.
#pragma omp parallel for schedule(static) if (n > 8192)
  for (Eigen::Index v = 0; v < n; ++v) {
    double a = 0.0, b = 0.0, d = 0.0;
    for (int k = 0; k < 4; ++k) {
      const int i = c[k * n + v];
      const double wk = w[k * n + v];
      a += wk * x0[i], b += wk * x1[i], d += wk * x2[i];
    }
    o0[v] = a, o1[v] = b, o2[v] = d;
  }
  if (s.offsets.rows() == n) out += s.offsets;
}

double max_amplification(const EmbeddedSurface& s) {
  return s.weights.rows() == 0 ? 0.0 : s.weights.cwiseAbs().rowwise().sum().maxCoeff();
}

int32_t offset_vertices(const EmbeddedSurface& s) {
  if (s.offsets.rows() == 0) return 0;
  return static_cast<int32_t>((s.offsets.rowwise().squaredNorm().array() > 0.0).count());
}

int32_t display_skin_index(const Model& model) {
  for (size_t i = 0; i < model.embedded.size(); ++i)
    if (model.embedded[i].role == SurfaceRole::kDisplaySkin) return static_cast<int32_t>(i);
  return -1;
}

}  // namespace lamina::model
