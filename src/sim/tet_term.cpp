// The tetrahedra (Material::young_modulus_kpa on a model with tetrahedra; docs/physics.md).
// Each tetrahedron stores
//   1/2 dl^T Q dl                   (its share of its six edge springs, and their coupling)
//   + 1/2 (k_v / V0) (V - V0)^2     (its signed volume; k_v from model::identify_tets)
// dl_k = l_k - L_k the stretch of edge k, Q from model::identify_tets, V the signed volume: an
// inverted tetrahedron (V < 0) is pushed back towards positive volume whatever its edge lengths,
// which a mirror image of it shares.
//
// Below a quarter of its rest volume a tetrahedron also meets a guard, (k_g / 2 V0)
// (V0 / 4 - V)^2 with k_g = 20 k_v: tissue is not compressed to nothing, and a tetrahedron
// pinned flat between an indenter's rim and the layer under it must still be pushed back to
// positive volume (the stability suite's 50% indentation left ten inverted without it). C1 at
// the threshold; its Gauss-Newton part joins the volume term's.
//
// Everything a tetrahedron needs is in one record (its nodes, rest lengths, Q, volume), so a
// pass streams the records and gathers four positions each. Like the springs, each pass writes
// only its own tetrahedron's row (12 values, one per corner and axis) and each node gathers its
// corners: no two threads write the same value, and the forces of a tetrahedron sum to zero.
#include <Eigen/Geometry>
#include <Eigen/SparseCore>

#include "solver.h"

namespace lamina::sim::detail {

using model::kTetEdge;

namespace {

constexpr double kGuardFraction = 0.25;   // the guard acts below this fraction of V0
constexpr double kGuardStiffness = 20.0;  // k_g / k_v

// The volume terms' pressure P (the force on corner c is -P dV/dx_c) and its derivative dP/dV.
inline double volume_pressure(const TetRecord& r, double volume, double& dp_dv) {
  double p = r.volume_stiffness * (volume - r.rest_volume_mm3);
  dp_dv = r.volume_stiffness;
  const double guard = kGuardFraction * r.rest_volume_mm3 - volume;
  if (guard > 0.0) {
    const double k = kGuardStiffness * r.volume_stiffness;
    p -= k * guard;
    dp_dv += k;
  }
  return p;
}

// Q's upper-triangle storage: row k starts at kRow[k] (its diagonal).
constexpr int kRow[6] = {0, 6, 11, 15, 18, 20};
inline int qi(int k, int m) { return k <= m ? kRow[k] + m - k : kRow[m] + k - m; }

// t = Q a for a symmetric 6x6 Q stored as its upper triangle.
inline void multiply_q(const float* q, const double a[6], double t[6]) {
  t[0] = q[0] * a[0] + q[1] * a[1] + q[2] * a[2] + q[3] * a[3] + q[4] * a[4] + q[5] * a[5];
  t[1] = q[1] * a[0] + q[6] * a[1] + q[7] * a[2] + q[8] * a[3] + q[9] * a[4] + q[10] * a[5];
  t[2] = q[2] * a[0] + q[7] * a[1] + q[11] * a[2] + q[12] * a[3] + q[13] * a[4] + q[14] * a[5];
  t[3] = q[3] * a[0] + q[8] * a[1] + q[12] * a[2] + q[15] * a[3] + q[16] * a[4] + q[17] * a[5];
  t[4] = q[4] * a[0] + q[9] * a[1] + q[13] * a[2] + q[16] * a[3] + q[18] * a[4] + q[19] * a[5];
  t[5] = q[5] * a[0] + q[10] * a[1] + q[14] * a[2] + q[17] * a[3] + q[19] * a[4] + q[20] * a[5];
}

// A tetrahedron's corners at x (12 values: corner c, axis d at 3c + d).
inline void load_corners(const ConstCols& x, const int32_t node[4], double p[12]) {
  for (int c = 0; c < 4; ++c) {
    const int32_t i = node[c];
    p[3 * c] = x.x[i], p[3 * c + 1] = x.y[i], p[3 * c + 2] = x.z[i];
  }
}

// dV/dx of each corner (12 values) and the signed volume, from the corners.
inline double volume_gradient(const double p[12], double g[12]) {
  const double ax = p[3] - p[0], ay = p[4] - p[1], az = p[5] - p[2];
  const double bx = p[6] - p[0], by = p[7] - p[1], bz = p[8] - p[2];
  const double cx = p[9] - p[0], cy = p[10] - p[1], cz = p[11] - p[2];
  // dV/dx1 = (b x c) / 6, dV/dx2 = (c x a) / 6, dV/dx3 = (a x b) / 6, dV/dx0 = -(their sum).
  g[3] = (by * cz - bz * cy) / 6.0, g[4] = (bz * cx - bx * cz) / 6.0, g[5] = (bx * cy - by * cx) / 6.0;
  g[6] = (cy * az - cz * ay) / 6.0, g[7] = (cz * ax - cx * az) / 6.0, g[8] = (cx * ay - cy * ax) / 6.0;
  g[9] = (ay * bz - az * by) / 6.0, g[10] = (az * bx - ax * bz) / 6.0, g[11] = (ax * by - ay * bx) / 6.0;
  for (int d = 0; d < 3; ++d) g[d] = -(g[3 + d] + g[6 + d] + g[9 + d]);
  return ax * g[3] + ay * g[4] + az * g[5];
}

// The corner forces of one tetrahedron at corners p (12 values out). With lin, also its
// linearisation and its diagonal share (12 values).
inline void tet_forces_at(const TetRecord& r, const double p[12], double f[12], TetLinear* lin,
                          double* diag) {
  double w[6][3], len[6], dl[6];
  for (int k = 0; k < 6; ++k) {
    const int a = 3 * kTetEdge[k][0], b = 3 * kTetEdge[k][1];
    const double ex = p[b] - p[a], ey = p[b + 1] - p[a + 1], ez = p[b + 2] - p[a + 2];
    len[k] = std::max(std::sqrt(ex * ex + ey * ey + ez * ez), 1e-12);
    w[k][0] = ex / len[k], w[k][1] = ey / len[k], w[k][2] = ez / len[k];
    dl[k] = len[k] - r.rest_length_mm[k];
  }
  double t[6];  // each edge's tension, mN
  multiply_q(r.q, dl, t);
  double g[12], dp_dv;
  const double pressure = volume_pressure(r, volume_gradient(p, g), dp_dv);
  for (int v = 0; v < 12; ++v) f[v] = -pressure * g[v];
  for (int k = 0; k < 6; ++k) {
    const int a = 3 * kTetEdge[k][0], b = 3 * kTetEdge[k][1];
    for (int d = 0; d < 3; ++d) {
      const double fd = t[k] * w[k][d];  // a stretched edge pulls its ends together
      f[a + d] += fd, f[b + d] -= fd;
    }
  }
  if (!lin) return;
  lin->volume_stiffness = static_cast<float>(dp_dv);
  for (int v = 0; v < 12; ++v) {
    lin->grad[v] = static_cast<float>(g[v]);
    diag[v] = dp_dv * g[v] * g[v];
  }
  for (int k = 0; k < 6; ++k) {
    // The geometric term t/l (I - w w^T), clamped at zero under compression so the matrix stays
    // positive definite (as for the springs).
    const double geo = std::max(0.0, t[k]) / len[k], qk = r.q[kRow[k]];
    lin->geo[k] = static_cast<float>(geo);
    const int a = 3 * kTetEdge[k][0], b = 3 * kTetEdge[k][1];
    for (int d = 0; d < 3; ++d) {
      lin->w[3 * k + d] = static_cast<float>(w[k][d]);
      const double kd = qk * w[k][d] * w[k][d] + geo * (1.0 - w[k][d] * w[k][d]);
      diag[a + d] += kd, diag[b + d] += kd;
    }
  }
}

}  // namespace

void setup_tets(Solver& s) {
  TetTerm& t = s.tets;
  const Model& m = *s.model;
  t.on = s.material.young_modulus_kpa > 0.0 && m.has_tets();
  if (!t.on) {
    t = TetTerm{};
    return;
  }
  t.id = model::identify_tets(
      m, {.young_modulus_kpa = s.material.young_modulus_kpa,
          .poisson_ratio = s.material.poisson_ratio},
      s.material.tet_elasticity);
  const Eigen::Index nt = m.tets.size();
  t.record.resize(static_cast<size_t>(nt));
  t.linear.assign(static_cast<size_t>(nt), TetLinear{});
  for (Eigen::Index q = 0; q < nt; ++q) {
    TetRecord& r = t.record[static_cast<size_t>(q)];
    for (int c = 0; c < 4; ++c) r.node[c] = m.tets.T(q, c);
    for (int k = 0; k < 6; ++k)
      r.rest_length_mm[k] = m.springs.rest_length_mm[static_cast<size_t>(t.id.tet_springs(q, k))];
    for (int v = 0; v < 21; ++v) r.q[v] = static_cast<float>(t.id.q_n_per_m(q, v));
    r.rest_volume_mm3 = t.id.rest_volume_mm3[static_cast<size_t>(q)];
    r.volume_stiffness = t.id.volume_modulus_kpa / r.rest_volume_mm3;
  }
  t.force = TetRows::Zero(nt, 12);
  t.product = TetRows::Zero(nt, 12);
  t.diag = TetRows::Zero(nt, 12);
  const int32_t n = m.node_count();
  t.corner_offsets.assign(static_cast<size_t>(n) + 1, 0);
  for (Eigen::Index q = 0; q < nt; ++q)
    for (int c = 0; c < 4; ++c) ++t.corner_offsets[m.tets.T(q, c) + 1];
  for (int32_t i = 0; i < n; ++i) t.corner_offsets[i + 1] += t.corner_offsets[i];
  t.corners.resize(static_cast<size_t>(t.corner_offsets[n]));
  std::vector<int32_t> fill(t.corner_offsets.begin(), t.corner_offsets.end() - 1);
  for (Eigen::Index q = 0; q < nt; ++q)
    for (int c = 0; c < 4; ++c) t.corners[fill[m.tets.T(q, c)]++] = static_cast<int32_t>(4 * q + c);
}

void tet_pass(Solver& s, const Eigen::MatrixX3d& xm, bool linearise, int threads) {
  TetTerm& tt = s.tets;
  const ConstCols x(xm);
  for_slices(static_cast<int64_t>(s.active_tets.size()), threads,
             [&](int64_t begin, int64_t end, int) {
               for (int64_t q = begin; q < end; ++q) {
                 const int64_t t = s.active_tets[q];
                 const TetRecord& r = tt.record[static_cast<size_t>(t)];
                 double p[12];
                 load_corners(x, r.node, p);
                 tet_forces_at(r, p, tt.force.data() + 12 * t,
                               linearise ? &tt.linear[static_cast<size_t>(t)] : nullptr,
                               tt.diag.data() + 12 * t);
               }
             });
}

// (K p) of one tetrahedron at its corners, K as linearised: per edge k, with d_k = p_b - p_a
// and a_k = w_k . d_k, the springs and coupling (Q a)_k w_k and the geometric term
// geo_k (d_k - a_k w_k) pull a towards b and b towards a; the volume term adds
// (k_v / V0) g (g . p). Its pressure-times-curvature part is left out, as for the volume term
// between layers: it is indefinite, and the matrix must stay positive definite for CG.
void tet_product_pass(Solver& s, const Eigen::MatrixX3d& pm, int threads) {
  TetTerm& tt = s.tets;
  const ConstCols p(pm);
  for_slices(static_cast<int64_t>(s.active_tets.size()), threads,
             [&](int64_t begin, int64_t end, int) {
               for (int64_t q = begin; q < end; ++q) {
                 const int64_t t = s.active_tets[q];
                 const TetRecord& r = tt.record[static_cast<size_t>(t)];
                 const TetLinear& l = tt.linear[static_cast<size_t>(t)];
                 double pc[12];
                 load_corners(p, r.node, pc);
                 double along = 0.0;
                 for (int v = 0; v < 12; ++v) along += l.grad[v] * pc[v];
                 along *= l.volume_stiffness;
                 double* y = tt.product.data() + 12 * t;
                 for (int v = 0; v < 12; ++v) y[v] = along * l.grad[v];
                 double d[6][3], a[6];
                 for (int k = 0; k < 6; ++k) {
                   const int ca = 3 * kTetEdge[k][0], cb = 3 * kTetEdge[k][1];
                   for (int e = 0; e < 3; ++e) d[k][e] = pc[cb + e] - pc[ca + e];
                   a[k] = l.w[3 * k] * d[k][0] + l.w[3 * k + 1] * d[k][1] + l.w[3 * k + 2] * d[k][2];
                 }
                 double c[6];
                 multiply_q(r.q, a, c);
                 for (int k = 0; k < 6; ++k) {
                   const int ca = 3 * kTetEdge[k][0], cb = 3 * kTetEdge[k][1];
                   for (int e = 0; e < 3; ++e) {
                     const double kp = c[k] * l.w[3 * k + e] + l.geo[k] * (d[k][e] - a[k] * l.w[3 * k + e]);
                     y[ca + e] -= kp, y[cb + e] += kp;
                   }
                 }
               }
             });
}

Eigen::Matrix<double, 1, 12> tet_corner_forces(const Solver& s, const Eigen::MatrixX3d& xm,
                                               int64_t t) {
  const TetRecord& r = s.tets.record[static_cast<size_t>(t)];
  double p[12];
  load_corners(ConstCols(xm), r.node, p);
  Eigen::Matrix<double, 1, 12> f;
  tet_forces_at(r, p, f.data(), nullptr, nullptr);
  return f;
}

void tet_forces(const Solver& s, const Eigen::MatrixX3d& xm, Eigen::MatrixX3d& f) {
  if (!s.tets.on) return;
  for (size_t t = 0; t < s.tets.record.size(); ++t) {
    const Eigen::Matrix<double, 1, 12> fc = tet_corner_forces(s, xm, static_cast<int64_t>(t));
    for (int c = 0; c < 4; ++c)
      for (int d = 0; d < 3; ++d) f(s.tets.record[t].node[c], d) += fc[3 * c + d];
  }
}

double tet_energy_mj(const Solver& s, const Eigen::MatrixX3d& xm) {
  if (!s.tets.on) return 0.0;
  const ConstCols x(xm);
  double e = 0.0;
  for (const TetRecord& r : s.tets.record) {
    double p[12], g[12], dl[6], t[6];
    load_corners(x, r.node, p);
    const double volume = volume_gradient(p, g), dv = volume - r.rest_volume_mm3;
    e += 0.5 * r.volume_stiffness * dv * dv;  // kPa mm^3 = 1e-6 J
    const double guard = kGuardFraction * r.rest_volume_mm3 - volume;
    if (guard > 0.0) e += 0.5 * kGuardStiffness * r.volume_stiffness * guard * guard;
    for (int k = 0; k < 6; ++k) {
      const int a = 3 * kTetEdge[k][0], b = 3 * kTetEdge[k][1];
      dl[k] = std::sqrt((p[b] - p[a]) * (p[b] - p[a]) + (p[b + 1] - p[a + 1]) * (p[b + 1] - p[a + 1]) +
                        (p[b + 2] - p[a + 2]) * (p[b + 2] - p[a + 2])) -
              r.rest_length_mm[k];
    }
    multiply_q(r.q, dl, t);
    for (int k = 0; k < 6; ++k) e += 0.5 * dl[k] * t[k];  // N/m mm^2 = 1e-6 J
  }
  return e;
}

void add_tet_stiffness_rows(const Solver& s, std::vector<double>& row) {
  if (!s.tets.on) return;
  const ConstCols x(s.model->X);
  for (const TetRecord& r : s.tets.record) {
    double p[12], g[12];
    load_corners(x, r.node, p);
    volume_gradient(p, g);
    // Volume: row a of k g g^T is bounded by |k g_a|_max sum_b |g_b|_1.
    double l1 = 0.0;
    for (double v : g) l1 += std::abs(v);
    for (int c = 0; c < 4; ++c) {
      const double gmax =
          std::max({std::abs(g[3 * c]), std::abs(g[3 * c + 1]), std::abs(g[3 * c + 2])});
      row[r.node[c]] += r.volume_stiffness * gmax * l1;
    }
    // Springs and coupling: corner a's row of J^T |Q| J, each 3x3 block w_k w_m^T bounded by
    // its largest row sum (<= sqrt 3): 2 sqrt 3 sum over a's edges k and all m of |Q_km|.
    for (int k = 0; k < 6; ++k) {
      double qsum = 0.0;
      for (int m = 0; m < 6; ++m) qsum += std::abs(r.q[qi(k, m)]);
      for (int end = 0; end < 2; ++end)
        row[r.node[kTetEdge[k][end]]] += 2.0 * std::sqrt(3.0) * qsum;
    }
  }
}

void add_tet_stiffness_triplets(const Solver& s, const std::vector<int32_t>& row_of,
                                std::vector<Eigen::Triplet<double>>& out) {
  if (!s.tets.on) return;
  const Eigen::MatrixX3d& X = s.model->X;
  const auto add_block = [&](int32_t na, int32_t nb, const Eigen::Matrix3d& b) {
    const int32_t r = row_of[na], c = row_of[nb];
    if (r < 0 || c < 0) return;
    for (int a = 0; a < 3; ++a)
      for (int d = 0; d < 3; ++d) out.emplace_back(3 * r + a, 3 * c + d, b(a, d));
  };
  for (const TetRecord& r : s.tets.record) {
    double p[12], g[12];
    load_corners(ConstCols(X), r.node, p);
    volume_gradient(p, g);
    // The volume term at rest: (k_v / V0) g g^T (its curvature part vanishes at V = V0).
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b)
        add_block(r.node[a], r.node[b],
                  r.volume_stiffness * Eigen::Vector3d(g[3 * a], g[3 * a + 1], g[3 * a + 2]) *
                      Eigen::RowVector3d(g[3 * b], g[3 * b + 1], g[3 * b + 2]));
    // Springs and coupling: J_k is -w_k at corner a, +w_k at corner b; K = J^T Q J (at rest the
    // edges are at their rest lengths: no geometric term).
    Eigen::Vector3d w[6];
    for (int k = 0; k < 6; ++k)
      w[k] = (X.row(r.node[kTetEdge[k][1]]) - X.row(r.node[kTetEdge[k][0]])).normalized().transpose();
    for (int k = 0; k < 6; ++k)
      for (int m = 0; m < 6; ++m)
        for (int ek = 0; ek < 2; ++ek)
          for (int em = 0; em < 2; ++em) {
            const double sign = (ek == 0 ? -1.0 : 1.0) * (em == 0 ? -1.0 : 1.0) * r.q[qi(k, m)];
            add_block(r.node[kTetEdge[k][ek]], r.node[kTetEdge[m][em]],
                      sign * w[k] * w[m].transpose());
          }
  }
}

}  // namespace lamina::sim::detail
