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
// The passes run over blocks of eight tetrahedra, one per SIMD lane: every loop below over
// `l < kTetLanes` is the same arithmetic on eight tetrahedra, which the compiler turns into
// vector instructions (gathers for the corners' positions). Each pass writes only its own
// block's rows and each node gathers its corners: no two threads write the same value, and the
// forces of a tetrahedron sum to zero.
#include <Eigen/Geometry>
#include <Eigen/SparseCore>

#include "solver.h"

namespace lamina::sim::detail {

using model::kTetEdge;

namespace {

constexpr int L = kTetLanes;
constexpr double kGuardFraction = 0.25;   // the guard acts below this fraction of V0
constexpr double kGuardStiffness = 20.0;  // k_g / k_v

// Q's upper-triangle storage: row k starts at kRow[k] (its diagonal).
constexpr int kRow[6] = {0, 6, 11, 15, 18, 20};
constexpr int qi(int k, int m) { return k <= m ? kRow[k] + m - k : kRow[m] + k - m; }

// Every helper below keeps the loop over a block's lanes innermost and free of branches, so
// that the compiler turns it into one vector instruction per statement (checked with
// -fopt-info-vec: docs/architecture.md).

// The corners' values (positions, or a CG direction) of a block, corner c and axis d at
// p[3 c + d][lane].
inline void load_corners(const TetBlock& b, const ConstCols& x, double p[12][L]) {
  for (int c = 0; c < 4; ++c) {
    const int32_t* node = b.node[c];
    for (int l = 0; l < L; ++l) p[3 * c][l] = x.x[node[l]];
    for (int l = 0; l < L; ++l) p[3 * c + 1][l] = x.y[node[l]];
    for (int l = 0; l < L; ++l) p[3 * c + 2][l] = x.z[node[l]];
  }
}

// The volume terms (with the guard): each lane's pressure P (corner c feels -P dV/dx_c), its
// derivative dP/dV, the gradient dV/dx and the volume.
struct VolumeParts {
  double g[12][L];
  double volume[L], pressure[L], dp_dv[L];
};

inline void volume_parts(const TetBlock& b, const double p[12][L], VolumeParts& o) {
  constexpr double s = 1.0 / 6.0;
  for (int l = 0; l < L; ++l) {
    const double ax = p[3][l] - p[0][l], ay = p[4][l] - p[1][l], az = p[5][l] - p[2][l];
    const double bx = p[6][l] - p[0][l], by = p[7][l] - p[1][l], bz = p[8][l] - p[2][l];
    const double cx = p[9][l] - p[0][l], cy = p[10][l] - p[1][l], cz = p[11][l] - p[2][l];
    // dV/dx1 = (b x c) / 6, dV/dx2 = (c x a) / 6, dV/dx3 = (a x b) / 6, dV/dx0 = -(their sum).
    const double g1x = s * (by * cz - bz * cy), g1y = s * (bz * cx - bx * cz),
                 g1z = s * (bx * cy - by * cx);
    const double g2x = s * (cy * az - cz * ay), g2y = s * (cz * ax - cx * az),
                 g2z = s * (cx * ay - cy * ax);
    const double g3x = s * (ay * bz - az * by), g3y = s * (az * bx - ax * bz),
                 g3z = s * (ax * by - ay * bx);
    o.g[0][l] = -(g1x + g2x + g3x), o.g[1][l] = -(g1y + g2y + g3y), o.g[2][l] = -(g1z + g2z + g3z);
    o.g[3][l] = g1x, o.g[4][l] = g1y, o.g[5][l] = g1z;
    o.g[6][l] = g2x, o.g[7][l] = g2y, o.g[8][l] = g2z;
    o.g[9][l] = g3x, o.g[10][l] = g3y, o.g[11][l] = g3z;
    const double v = ax * g1x + ay * g1y + az * g1z;
    const double k = b.volume_stiffness[l], v0 = b.rest_volume_mm3[l];
    const double below = kGuardFraction * v0 - v;
    const bool guarded = below > 0.0;
    o.volume[l] = v;
    o.pressure[l] = k * (v - v0) - (guarded ? kGuardStiffness * k * below : 0.0);
    o.dp_dv[l] = guarded ? (1.0 + kGuardStiffness) * k : k;
  }
}

// The edges of a block at corners p: unit directions w, lengths and stretches.
struct EdgeParts {
  double w[6][3][L];
  double length[6][L], stretch[6][L];
};

inline void edge_parts(const TetBlock& b, const double p[12][L], EdgeParts& o) {
  for (int k = 0; k < 6; ++k) {
    const double* ax = p[3 * kTetEdge[k][0]];
    const double* ay = p[3 * kTetEdge[k][0] + 1];
    const double* az = p[3 * kTetEdge[k][0] + 2];
    const double* bx = p[3 * kTetEdge[k][1]];
    const double* by = p[3 * kTetEdge[k][1] + 1];
    const double* bz = p[3 * kTetEdge[k][1] + 2];
    for (int l = 0; l < L; ++l) {
      const double ex = bx[l] - ax[l], ey = by[l] - ay[l], ez = bz[l] - az[l];
      const double raw = std::sqrt(ex * ex + ey * ey + ez * ez);
      const double len = raw > 1e-12 ? raw : 1e-12;  // a collapsed edge has no direction
      const double inv = 1.0 / len;
      o.w[k][0][l] = ex * inv, o.w[k][1][l] = ey * inv, o.w[k][2][l] = ez * inv;
      o.length[k][l] = len;
      o.stretch[k][l] = len - b.rest_length_mm[k][l];
    }
  }
}

// t = Q a on every lane (Q symmetric, its upper triangle stored).
inline void multiply_q(const TetBlock& b, const double a[6][L], double t[6][L]) {
  for (int k = 0; k < 6; ++k) {
    double sum[L];
    for (int l = 0; l < L; ++l) sum[l] = b.q[qi(k, 0)][l] * a[0][l];
    for (int m = 1; m < 6; ++m)
      for (int l = 0; l < L; ++l) sum[l] += b.q[qi(k, m)][l] * a[m][l];
    for (int l = 0; l < L; ++l) t[k][l] = sum[l];
  }
}

// The corner forces of a block at corners p; with lin, also its linearisation and diagonal.
void block_forces(const TetBlock& b, const double p[12][L], double f[12][L],
                  TetBlockLinear* lin, double diag[12][L]) {
  EdgeParts e;
  edge_parts(b, p, e);
  VolumeParts vol;
  volume_parts(b, p, vol);
  double t[6][L];  // each edge's tension, mN
  multiply_q(b, e.stretch, t);
  for (int v = 0; v < 12; ++v)
    for (int l = 0; l < L; ++l) f[v][l] = -vol.pressure[l] * vol.g[v][l];
  for (int k = 0; k < 6; ++k)
    for (int d = 0; d < 3; ++d) {
      double* fa = f[3 * kTetEdge[k][0] + d];
      double* fb = f[3 * kTetEdge[k][1] + d];
      for (int l = 0; l < L; ++l) {
        const double fd = t[k][l] * e.w[k][d][l];  // a stretched edge pulls its ends together
        fa[l] += fd, fb[l] -= fd;
      }
    }
  if (!lin) return;
  for (int l = 0; l < L; ++l) lin->volume_stiffness[l] = static_cast<float>(vol.dp_dv[l]);
  for (int v = 0; v < 12; ++v)
    for (int l = 0; l < L; ++l) {
      lin->grad[v][l] = static_cast<float>(vol.g[v][l]);
      diag[v][l] = vol.dp_dv[l] * vol.g[v][l] * vol.g[v][l];
    }
  for (int k = 0; k < 6; ++k) {
    // The geometric term t/l (I - w w^T), clamped at zero under compression so the matrix stays
    // positive definite (as for the springs).
    double geo[L];
    for (int l = 0; l < L; ++l) {
      geo[l] = (t[k][l] > 0.0 ? t[k][l] : 0.0) / e.length[k][l];
      lin->geo[k][l] = static_cast<float>(geo[l]);
    }
    const float* qk = b.q[kRow[k]];
    for (int d = 0; d < 3; ++d) {
      double* da = diag[3 * kTetEdge[k][0] + d];
      double* db = diag[3 * kTetEdge[k][1] + d];
      for (int l = 0; l < L; ++l) {
        const double w = e.w[k][d][l];
        lin->w[3 * k + d][l] = static_cast<float>(w);
        const double kd = qk[l] * w * w + geo[l] * (1.0 - w * w);
        da[l] += kd, db[l] += kd;
      }
    }
  }
}

// (K p) of a block at its corners, K as linearised: per edge k, with d_k = p_b - p_a and
// a_k = w_k . d_k, the springs and coupling (Q a)_k w_k and the geometric term
// geo_k (d_k - a_k w_k) act along the edge; the volume terms add dP/dV g (g . p). Their
// pressure-times-curvature part is left out, as for the volume term between layers: it is
// indefinite, and the matrix must stay positive definite for CG.
void block_product(const TetBlock& b, const TetBlockLinear& lin, const double p[12][L],
                   double y[12][L]) {
  double along[L];
  for (int l = 0; l < L; ++l) along[l] = lin.grad[0][l] * p[0][l];
  for (int v = 1; v < 12; ++v)
    for (int l = 0; l < L; ++l) along[l] += lin.grad[v][l] * p[v][l];
  for (int l = 0; l < L; ++l) along[l] *= lin.volume_stiffness[l];
  for (int v = 0; v < 12; ++v)
    for (int l = 0; l < L; ++l) y[v][l] = along[l] * lin.grad[v][l];
  double d[6][3][L], a[6][L];
  for (int k = 0; k < 6; ++k) {
    for (int e = 0; e < 3; ++e) {
      const double* pa = p[3 * kTetEdge[k][0] + e];
      const double* pb = p[3 * kTetEdge[k][1] + e];
      for (int l = 0; l < L; ++l) d[k][e][l] = pb[l] - pa[l];
    }
    for (int l = 0; l < L; ++l)
      a[k][l] = lin.w[3 * k][l] * d[k][0][l] + lin.w[3 * k + 1][l] * d[k][1][l] +
                lin.w[3 * k + 2][l] * d[k][2][l];
  }
  double c[6][L];
  multiply_q(b, a, c);
  for (int k = 0; k < 6; ++k)
    for (int e = 0; e < 3; ++e) {
      double* ya = y[3 * kTetEdge[k][0] + e];
      double* yb = y[3 * kTetEdge[k][1] + e];
      const float* w = lin.w[3 * k + e];
      for (int l = 0; l < L; ++l) {
        const double kp = c[k][l] * w[l] + lin.geo[k][l] * (d[k][e][l] - a[k][l] * w[l]);
        ya[l] -= kp, yb[l] += kp;
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
  const size_t blocks = static_cast<size_t>((nt + L - 1) / L);
  // Unused lanes of the last block: every corner node 0, no stiffness, a unit rest volume (no
  // force, and no node gathers them).
  TetBlock empty{};
  for (int l = 0; l < L; ++l) empty.rest_volume_mm3[l] = 1.0;
  t.block.assign(blocks, empty);
  for (Eigen::Index q = 0; q < nt; ++q) {
    TetBlock& b = t.block[static_cast<size_t>(q / L)];
    const int l = static_cast<int>(q % L);
    for (int c = 0; c < 4; ++c) b.node[c][l] = m.tets.T(q, c);
    for (int k = 0; k < 6; ++k)
      b.rest_length_mm[k][l] =
          m.springs.rest_length_mm[static_cast<size_t>(t.id.tet_springs(q, k))];
    for (int v = 0; v < 21; ++v) b.q[v][l] = static_cast<float>(t.id.q_n_per_m(q, v));
    b.rest_volume_mm3[l] = t.id.rest_volume_mm3[static_cast<size_t>(q)];
    b.volume_stiffness[l] = t.id.volume_modulus_kpa / b.rest_volume_mm3[l];
  }
  t.linear.assign(blocks, TetBlockLinear{});
  t.force.assign(blocks, TetBlockRows{});
  t.product.assign(blocks, TetBlockRows{});
  t.diag.assign(blocks, TetBlockRows{});
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
                 const auto k = static_cast<size_t>(s.active_tets[q]);
                 double p[12][L];
                 load_corners(tt.block[k], x, p);
                 block_forces(tt.block[k], p, tt.force[k].v, linearise ? &tt.linear[k] : nullptr,
                              tt.diag[k].v);
               }
             });
}

void tet_product_pass(Solver& s, const Eigen::MatrixX3d& pm, int threads) {
  TetTerm& tt = s.tets;
  const ConstCols p(pm);
  for_slices(static_cast<int64_t>(s.active_tets.size()), threads,
             [&](int64_t begin, int64_t end, int) {
               for (int64_t q = begin; q < end; ++q) {
                 const auto k = static_cast<size_t>(s.active_tets[q]);
                 double pc[12][L];
                 load_corners(tt.block[k], p, pc);
                 block_product(tt.block[k], tt.linear[k], pc, tt.product[k].v);
               }
             });
}

Eigen::Matrix<double, 1, 12> tet_corner_forces(const Solver& s, const Eigen::MatrixX3d& xm,
                                               int64_t t) {
  const TetBlock& b = s.tets.block[static_cast<size_t>(t / L)];
  double p[12][L], f[12][L];
  load_corners(b, ConstCols(xm), p);
  block_forces(b, p, f, nullptr, nullptr);
  Eigen::Matrix<double, 1, 12> out;
  for (int v = 0; v < 12; ++v) out[v] = f[v][t % L];
  return out;
}

void tet_forces(const Solver& s, const Eigen::MatrixX3d& xm, Eigen::MatrixX3d& f) {
  if (!s.tets.on) return;
  const ConstCols x(xm);
  for (const TetBlock& b : s.tets.block) {
    double p[12][L], fc[12][L];
    load_corners(b, x, p);
    block_forces(b, p, fc, nullptr, nullptr);
    for (int c = 0; c < 4; ++c)
      for (int l = 0; l < L; ++l)
        for (int d = 0; d < 3; ++d) f(b.node[c][l], d) += fc[3 * c + d][l];
  }
}

double tet_energy_mj(const Solver& s, const Eigen::MatrixX3d& xm) {
  if (!s.tets.on) return 0.0;
  const ConstCols x(xm);
  double e = 0.0;
  for (const TetBlock& b : s.tets.block) {
    double p[12][L], t[6][L];
    load_corners(b, x, p);
    EdgeParts edges;
    edge_parts(b, p, edges);
    VolumeParts vol;
    volume_parts(b, p, vol);
    multiply_q(b, edges.stretch, t);
    for (int l = 0; l < L; ++l) {
      const double dv = vol.volume[l] - b.rest_volume_mm3[l];
      const double guard = std::max(0.0, kGuardFraction * b.rest_volume_mm3[l] - vol.volume[l]);
      // kPa mm^3 = N/m mm^2 = 1e-6 J
      e += 0.5 * b.volume_stiffness[l] * (dv * dv + kGuardStiffness * guard * guard);
      for (int k = 0; k < 6; ++k) e += 0.5 * edges.stretch[k][l] * t[k][l];
    }
  }
  return e;
}

void add_tet_stiffness_rows(const Solver& s, std::vector<double>& row) {
  if (!s.tets.on) return;
  const ConstCols x(s.model->X);
  for (const TetBlock& b : s.tets.block) {
    double p[12][L];
    load_corners(b, x, p);
    VolumeParts vol;
    volume_parts(b, p, vol);
    for (int l = 0; l < L; ++l) {
      // Volume: row a of k g g^T is bounded by |k g_a|_max sum_b |g_b|_1.
      double l1 = 0.0;
      for (int v = 0; v < 12; ++v) l1 += std::abs(vol.g[v][l]);
      for (int c = 0; c < 4; ++c) {
        const double gmax = std::max({std::abs(vol.g[3 * c][l]), std::abs(vol.g[3 * c + 1][l]),
                                      std::abs(vol.g[3 * c + 2][l])});
        row[b.node[c][l]] += b.volume_stiffness[l] * gmax * l1;
      }
      // Springs and coupling: corner a's row of J^T |Q| J, each 3x3 block w_k w_m^T bounded
      // by its largest row sum (<= sqrt 3): 2 sqrt 3 sum over a's edges k and all m of |Q_km|.
      for (int k = 0; k < 6; ++k) {
        double qsum = 0.0;
        for (int m = 0; m < 6; ++m) qsum += std::abs(b.q[qi(k, m)][l]);
        for (int end = 0; end < 2; ++end)
          row[b.node[kTetEdge[k][end]][l]] += 2.0 * std::sqrt(3.0) * qsum;
      }
    }
  }
}

void add_tet_stiffness_triplets(const Solver& s, const std::vector<int32_t>& row_of,
                                std::vector<Eigen::Triplet<double>>& out) {
  if (!s.tets.on) return;
  const Eigen::MatrixX3d& X = s.model->X;
  const auto add_block = [&](int32_t na, int32_t nb, const Eigen::Matrix3d& m) {
    const int32_t r = row_of[na], c = row_of[nb];
    if (r < 0 || c < 0) return;
    for (int a = 0; a < 3; ++a)
      for (int d = 0; d < 3; ++d) out.emplace_back(3 * r + a, 3 * c + d, m(a, d));
  };
  for (const TetBlock& b : s.tets.block) {
    double p[12][L];
    load_corners(b, ConstCols(X), p);
    VolumeParts vol;
    volume_parts(b, p, vol);
    for (int l = 0; l < L; ++l) {
      if (b.volume_stiffness[l] == 0.0) continue;  // an unused lane
      // The volume term at rest: (k_v / V0) g g^T (its curvature part vanishes at V = V0).
      for (int a = 0; a < 4; ++a)
        for (int c = 0; c < 4; ++c)
          add_block(b.node[a][l], b.node[c][l],
                    b.volume_stiffness[l] *
                        Eigen::Vector3d(vol.g[3 * a][l], vol.g[3 * a + 1][l], vol.g[3 * a + 2][l]) *
                        Eigen::RowVector3d(vol.g[3 * c][l], vol.g[3 * c + 1][l], vol.g[3 * c + 2][l]));
      // Springs and coupling: J_k is -w_k at corner a, +w_k at corner b; K = J^T Q J (at rest
      // the edges are at their rest lengths: no geometric term).
      Eigen::Vector3d w[6];
      for (int k = 0; k < 6; ++k)
        w[k] = (X.row(b.node[kTetEdge[k][1]][l]) - X.row(b.node[kTetEdge[k][0]][l]))
                   .normalized()
                   .transpose();
      for (int k = 0; k < 6; ++k)
        for (int m = 0; m < 6; ++m)
          for (int ek = 0; ek < 2; ++ek)
            for (int em = 0; em < 2; ++em) {
              const double sign =
                  (ek == 0 ? -1.0 : 1.0) * (em == 0 ? -1.0 : 1.0) * b.q[qi(k, m)][l];
              add_block(b.node[kTetEdge[k][ek]][l], b.node[kTetEdge[m][em]][l],
                        sign * w[k] * w[m].transpose());
            }
    }
  }
}

}  // namespace lamina::sim::detail
