// The tetrahedra (Material::young_modulus_kpa on a model with tetrahedra; docs/physics.md).
// Each tetrahedron stores
//   1/2 dl^T Q dl                   (its share of its six edge springs, and their coupling)
//   + 1/2 (k_v / V0) (V - V0)^2     (its signed volume; k_v from model::identify_tets)
// dl_k = l_k - L_k the stretch of edge k, Q from model::identify_tets, V the signed volume: an
// inverted tetrahedron (V < 0) is pushed back towards positive volume whatever its edge lengths,
// which a mirror image of it shares.
//
// Below a tenth of its rest volume a tetrahedron also meets a guard, (k_g / 2 V0)
// (V0 / 10 - V)^2 with k_g = 100 (lambda + 2 mu): tissue is not compressed to nothing, and a
// tetrahedron pinned flat between an indenter's rim and the layer under it must still be pushed
// back to positive volume (the stability suite's 50% indentation left seven inverted with a
// fifth of that guard, ten without one; docs/physics.md). C1 at
// the threshold; its Gauss-Newton part joins the volume term's.
//
// The passes run over blocks of kTetLanes tetrahedra (8 or 4, solver.h), one per SIMD lane:
// every loop below over `l < kTetLanes` is the same arithmetic on a block's tetrahedra, which
// the compiler turns into vector instructions (gathers for the corners' positions). Each pass
// writes only its own block's rows and each node gathers its corners: no two threads write the same
// value, and the forces of a tetrahedron sum to zero.
#include <Eigen/Geometry>
#include <Eigen/SparseCore>
#include <array>

#include "force_terms.h"
#include "solver.h"
#include "tet_lanes.h"

namespace lamina::sim::detail {

using model::kTetEdge;
using namespace lanes_of_tets;

namespace {

constexpr double kGuardFraction = 0.1;  // the guard acts below this fraction of V0
// From this many tetrahedra implicit Euler assembles their stiffness once a step (TetAssembly).
// Measured (docs/benchmarks.md): at 10,014 (the paper-size liver, its element data within the
// caches) assembling makes a 1 ms step 1.2-2x slower; at 101,730 it is a trade, 1.2x slower
// settled at 1 ms (about 8 CG products a step do not repay it) and 1.3-2.3x faster at 10 ms; at
// 432,017, 2.5-3.3x faster at both.
constexpr int64_t kAssembleFromTets = 200000;

// Q's upper-triangle storage: row k starts at kRow[k] (its diagonal).
constexpr int kRow[6] = {0, 6, 11, 15, 18, 20};
constexpr int qi(int k, int m) {
  return k <= m ? kRow[k] + m - k : kRow[m] + k - m;
}

// The three edges meeting at each corner (from kTetEdge), and -1 or +1 as the corner is the
// edge's first or second end.
constexpr int kCornerEdge[4][3] = {{0, 1, 2}, {0, 3, 4}, {1, 3, 5}, {2, 4, 5}};
constexpr double kCornerSign[4][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {1, 1, 1}};
constexpr bool corner_table_matches_edges() {
  for (int n = 0; n < 4; ++n)
    for (int j = 0; j < 3; ++j) {
      const int k = kCornerEdge[n][j];
      if (kTetEdge[k][kCornerSign[n][j] < 0 ? 0 : 1] != n) return false;
    }
  return true;
}
static_assert(corner_table_matches_edges());

// The volume terms (with the guard): each lane's pressure P (corner c feels -P dV/dx_c), its
// derivative dP/dV, the gradient dV/dx and the volume.
struct VolumeParts {
  Lanes g[12];
  Lanes volume, pressure, dp_dv;
};

inline void volume_parts(const TetBlock& b, const Lanes p[12], VolumeParts& o) {
  const Lanes ax = p[3] - p[0], ay = p[4] - p[1], az = p[5] - p[2];
  const Lanes bx = p[6] - p[0], by = p[7] - p[1], bz = p[8] - p[2];
  const Lanes cx = p[9] - p[0], cy = p[10] - p[1], cz = p[11] - p[2];
  // dV/dx1 = (b x c) / 6, dV/dx2 = (c x a) / 6, dV/dx3 = (a x b) / 6, dV/dx0 = -(their sum).
  const double s = 1.0 / 6.0;
  o.g[3] = s * (by * cz - bz * cy), o.g[4] = s * (bz * cx - bx * cz),
  o.g[5] = s * (bx * cy - by * cx);
  o.g[6] = s * (cy * az - cz * ay), o.g[7] = s * (cz * ax - cx * az),
  o.g[8] = s * (cx * ay - cy * ax);
  o.g[9] = s * (ay * bz - az * by), o.g[10] = s * (az * bx - ax * bz),
  o.g[11] = s * (ax * by - ay * bx);
  for (int d = 0; d < 3; ++d) o.g[d] = -(o.g[3 + d] + o.g[6 + d] + o.g[9 + d]);
  o.volume = ax * o.g[3] + ay * o.g[4] + az * o.g[5];
  const Lanes k = lanes(b.volume_stiffness), kg = lanes(b.guard_stiffness);
  const Lanes v0 = lanes(b.rest_volume_mm3);
  const Lanes below = max(kGuardFraction * v0 - o.volume, Lanes{});
  o.pressure = k * (o.volume - v0) - kg * below;
  o.dp_dv = below > 0.0 ? k + kg : k;
}

// The edges of a block at corners p: unit directions w, lengths and stretches.
struct EdgeParts {
  Lanes w[6][3];
  Lanes length[6], stretch[6];
};

inline void edge_parts(const TetBlock& b, const Lanes p[12], EdgeParts& o) {
  for (int k = 0; k < 6; ++k) {
    const int a = 3 * kTetEdge[k][0], c = 3 * kTetEdge[k][1];
    const Lanes ex = p[c] - p[a], ey = p[c + 1] - p[a + 1], ez = p[c + 2] - p[a + 2];
    const Lanes len =
        max(sqrt(ex * ex + ey * ey + ez * ez), splat(1e-12));  // collapsed: no direction
    const Lanes inv = 1.0 / len;
    o.w[k][0] = ex * inv, o.w[k][1] = ey * inv, o.w[k][2] = ez * inv;
    o.length[k] = len;
    o.stretch[k] = len - lanes(b.rest_length_mm[k]);
  }
}

// A block's Q, its upper triangle, widened to double lanes.
inline void load_q(const TetBlock& b, Lanes q[21]) {
  for (int v = 0; v < 21; ++v) q[v] = lanes(b.q[v]);
}

// t = Q a on every lane (Q symmetric, its upper triangle stored).
inline void multiply_q(const Lanes q[21], const Lanes a[6], Lanes t[6]) {
  for (int k = 0; k < 6; ++k) {
    Lanes sum = q[qi(k, 0)] * a[0];
    for (int m = 1; m < 6; ++m) sum += q[qi(k, m)] * a[m];
    t[k] = sum;
  }
}

// The corner forces of a block at corners p; with lin, also its linearisation and diagonal.
void block_forces(const TetBlock& b, const Lanes p[12], Lanes f[12], TetBlockLinear* lin,
                  Lanes diag[12]) {
  EdgeParts e;
  edge_parts(b, p, e);
  VolumeParts vol;
  volume_parts(b, p, vol);
  Lanes q[21];
  load_q(b, q);
  Lanes t[6];  // each edge's tension, mN
  multiply_q(q, e.stretch, t);
  for (int v = 0; v < 12; ++v) f[v] = -vol.pressure * vol.g[v];
  for (int k = 0; k < 6; ++k) {
    const int a = 3 * kTetEdge[k][0], c = 3 * kTetEdge[k][1];
    for (int d = 0; d < 3; ++d) {
      const Lanes fd = t[k] * e.w[k][d];  // a stretched edge pulls its ends together
      f[a + d] += fd, f[c + d] -= fd;
    }
  }
  if (!lin) return;
  store(vol.dp_dv, lin->volume_stiffness);
  for (int v = 0; v < 12; ++v) {
    store(vol.g[v], lin->grad[v]);
    diag[v] = vol.dp_dv * vol.g[v] * vol.g[v];
  }
  for (int k = 0; k < 6; ++k) {
    // The geometric term t/l (I - w w^T), clamped at zero under compression so the matrix stays
    // positive definite (as for the springs).
    const Lanes geo = max(t[k], Lanes{}) / e.length[k];
    store(geo, lin->geo[k]);
    const int a = 3 * kTetEdge[k][0], c = 3 * kTetEdge[k][1];
    for (int d = 0; d < 3; ++d) {
      const Lanes w = e.w[k][d];
      store(w, lin->w[3 * k + d]);
      const Lanes kd = geo * (1.0 - w * w);
      diag[a + d] += kd, diag[c + d] += kd;
    }
  }
  // The springs' and coupling's diagonal, exactly: at corner n and direction d, u^T Q u over the
  // three edges meeting at n, u_k = -w_k,d or +w_k,d as n is the edge's first or second end.
  // Q's off-diagonal terms (lambda's coupling) enter it; Q_kk w^2 alone missed them, and with
  // 90% of lambda in Q the Jacobi preconditioner then took twice the CG iterations
  // (docs/architecture.md).
  for (int n = 0; n < 4; ++n)
    for (int d = 0; d < 3; ++d) {
      Lanes u[3];
      for (int j = 0; j < 3; ++j) u[j] = kCornerSign[n][j] * e.w[kCornerEdge[n][j]][d];
      Lanes sum = Lanes{};
      for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 3; ++i)
          sum += q[qi(kCornerEdge[n][j], kCornerEdge[n][i])] * u[j] * u[i];
      diag[3 * n + d] += sum;
    }
}

// (K p) of a block at its corners, K as linearised: per edge k, with d_k = p_b - p_a and
// a_k = w_k . d_k, the springs and coupling (Q a)_k w_k and the geometric term
// geo_k (d_k - a_k w_k) act along the edge; the volume terms add dP/dV g (g . p). Their
// pressure-times-curvature part is left out, as for the volume term between layers: it is
// indefinite, and the matrix must stay positive definite for CG.
//
// Each value is loaded (and widened from float) where it is used rather than kept in arrays: a
// block is one register a value, and the arrays' 60-odd live values spilled (a 4 KB stack frame
// on AVX-512); the sums are the same, in the same order. Every loop unrolled: the edges' corners
// and Q's entries become constants (GCC left the loops with their index arithmetic).
void block_product(const TetBlock& b, const TetBlockLinear& lin, const Lanes p[12], Lanes y[12]) {
  Lanes along = Lanes{};
#pragma GCC unroll 16
  for (int v = 0; v < 12; ++v) along += lanes(lin.grad[v]) * p[v];
  along *= lanes(lin.volume_stiffness);
#pragma GCC unroll 16
  for (int v = 0; v < 12; ++v) y[v] = along * lanes(lin.grad[v]);
  Lanes a[6];
#pragma GCC unroll 16
  for (int k = 0; k < 6; ++k) {
    const int ca = 3 * kTetEdge[k][0], cb = 3 * kTetEdge[k][1];
    a[k] = Lanes{};
#pragma GCC unroll 16
    for (int e = 0; e < 3; ++e) a[k] += lanes(lin.w[3 * k + e]) * (p[cb + e] - p[ca + e]);
  }
  Lanes c[6];  // Q a
#pragma GCC unroll 16
  for (int k = 0; k < 6; ++k) {
    c[k] = lanes(b.q[qi(k, 0)]) * a[0];
#pragma GCC unroll 16
    for (int m = 1; m < 6; ++m) c[k] += lanes(b.q[qi(k, m)]) * a[m];
  }
#pragma GCC unroll 16
  for (int k = 0; k < 6; ++k) {
    const int ca = 3 * kTetEdge[k][0], cb = 3 * kTetEdge[k][1];
    const Lanes geo = lanes(lin.geo[k]);
#pragma GCC unroll 16
    for (int e = 0; e < 3; ++e) {
      const Lanes w = lanes(lin.w[3 * k + e]), d = p[cb + e] - p[ca + e];
      const Lanes kp = c[k] * w + geo * (d - a[k] * w);
      y[ca + e] -= kp, y[cb + e] += kp;
    }
  }
}

// The 16 3x3 blocks of K (row corner r, column corner c: out[4 r + c][3 a + d]) of a linearised
// block, the matrix block_product() applies: with s_kr = -1, +1 or 0 as corner r is edge k's
// first end, second or neither,
//   K_rc = dP/dV g_r g_c^T + sum_k,m s_kr s_mc Q_km w_k w_m^T
//          + sum_k s_kr s_kc geo_k (I - w_k w_k^T).
// The coupling's sum goes through z_kc = sum_m s_mc Q_km w_m (three edges meet at each corner).
void linear_block_stiffness(const TetBlock& b, const TetBlockLinear& lin, Lanes out[16][9]) {
  Lanes g[12], w[6][3], q[21];
  for (int v = 0; v < 12; ++v) g[v] = lanes(lin.grad[v]);
  for (int k = 0; k < 6; ++k)
    for (int e = 0; e < 3; ++e) w[k][e] = lanes(lin.w[3 * k + e]);
  load_q(b, q);
  const Lanes kv = lanes(lin.volume_stiffness);
  Lanes z[6][4][3];
  for (int k = 0; k < 6; ++k)
    for (int c = 0; c < 4; ++c)
      for (int e = 0; e < 3; ++e) {
        Lanes sum = Lanes{};
        for (int j = 0; j < 3; ++j) {
          const int m = kCornerEdge[c][j];
          sum += kCornerSign[c][j] * q[qi(k, m)] * w[m][e];
        }
        z[k][c][e] = sum;
      }
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) {
      Lanes* o = out[4 * r + c];
      for (int a = 0; a < 3; ++a)
        for (int d = 0; d < 3; ++d) {
          Lanes sum = kv * g[3 * r + a] * g[3 * c + d];
          for (int j = 0; j < 3; ++j) {
            const int k = kCornerEdge[r][j];
            sum += kCornerSign[r][j] * w[k][a] * z[k][c][d];
          }
          o[3 * a + d] = sum;
        }
    }
  for (int k = 0; k < 6; ++k) {
    const int ends[2] = {kTetEdge[k][0], kTetEdge[k][1]};
    const Lanes geo = lanes(lin.geo[k]);
    for (int x = 0; x < 2; ++x)
      for (int y = 0; y < 2; ++y) {
        const Lanes sg = x == y ? geo : -geo;
        Lanes* o = out[4 * ends[x] + ends[y]];
        for (int a = 0; a < 3; ++a)
          for (int d = 0; d < 3; ++d)
            o[3 * a + d] += sg * ((a == d ? 1.0 : 0.0) - w[k][a] * w[k][d]);
      }
  }
}

}  // namespace

void add_element_blocks(const Eigen::Matrix<double, 12, 12>& k12, const int32_t corner[4],
                        const std::vector<int32_t>& row_of, BlockRows& out) {
  for (int a = 0; a < 4; ++a) {
    const int32_t r = row_of[corner[a]];
    if (r < 0) continue;
    for (int c = 0; c < 4; ++c) {
      const int32_t col = row_of[corner[c]];
      if (col < 0) continue;
      double* block = out.at(r, col);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) block[3 * i + j] += k12(3 * a + i, 3 * c + j);
    }
  }
}

void setup_tets(Solver& s, const KnownTets* known) {
  TetTerm& t = s.tets;
  const Model& m = *s.model;
  t.on = s.material.young_modulus_kpa > 0.0 && m.has_tets();
  if (!t.on) {
    t = TetTerm{};
    return;
  }
  const model::ElasticMaterial elastic{.young_modulus_kpa = s.material.young_modulus_kpa,
                                       .poisson_ratio = s.material.poisson_ratio};
  t.id = std::make_shared<const model::TetIdentification>(
      known && known->before
          ? model::identify_tets(m, elastic, s.material.tet_elasticity, known->tables)
          : model::identify_tets(m, elastic, s.material.tet_elasticity));
  const Eigen::Index nt = m.tets.size();
  const size_t blocks = static_cast<size_t>((nt + L - 1) / L);
  // Unused lanes of the last block: every corner node 0, no stiffness, a unit rest volume (no
  // force, and no node gathers them).
  TetBlock empty{};
  for (int l = 0; l < L; ++l) empty.rest_volume_mm3[l] = 1.0;
  t.block.assign(blocks, empty);
  for (Eigen::Index q = 0; q < nt; ++q)
    for (int c = 0; c < 4; ++c) t.block[static_cast<size_t>(q / L)].node[c][q % L] = m.tets.T(q, c);
  t.linear.assign(blocks, TetBlockLinear{});
  // Rows for every lane of every block (the unused lanes' are written and never read).
  for (TetRows* rows : {&t.force, &t.product, &t.diag}) rows->assign(12 * L * blocks, 0.0f);
  const int32_t n = m.node_count();
  t.corner_offsets.assign(static_cast<size_t>(n) + 1, 0);
  for (Eigen::Index q = 0; q < nt; ++q)
    for (int c = 0; c < 4; ++c) ++t.corner_offsets[m.tets.T(q, c) + 1];
  for (int32_t i = 0; i < n; ++i) t.corner_offsets[i + 1] += t.corner_offsets[i];
  t.corners.resize(static_cast<size_t>(t.corner_offsets[n]));
  std::vector<int32_t> fill(t.corner_offsets.begin(), t.corner_offsets.end() - 1);
  for (Eigen::Index q = 0; q < nt; ++q)
    for (int c = 0; c < 4; ++c) t.corners[fill[m.tets.T(q, c)]++] = static_cast<int32_t>(4 * q + c);
  t.neo_hookean = s.material.tet_model == TetModel::kNeoHookean;
  with_tet_energy(s, [&](auto energy) { decltype(energy)::setup(s); });
  if (nt >= kAssembleFromTets) setup_tet_assembly(s);
}

void CoupledTets::setup(Solver& s) {
  TetTerm& t = s.tets;
  const model::TetIdentification& id = *t.id;
  const Model& m = *s.model;
  // On the threads (a cut makes the blocks again: 4.5 ms of a 48k-node event on one); a block's
  // lanes on one thread.
  const Eigen::Index nt = m.tets.size();
#pragma omp parallel for schedule(static)
  for (Eigen::Index q = 0; q < nt; ++q) {
    TetBlock& b = t.block[static_cast<size_t>(q / L)];
    const int l = static_cast<int>(q % L);
    for (int k = 0; k < 6; ++k)
      b.rest_length_mm[k][l] = m.springs.rest_length_mm[static_cast<size_t>(id.tet_springs(q, k))];
    for (int v = 0; v < 21; ++v) b.q[v][l] = static_cast<float>(id.q_n_per_m(q, v));
    b.rest_volume_mm3[l] = id.rest_volume_mm3[static_cast<size_t>(q)];
    // A cut's copy carries its share of the tetrahedron's material (Q already has it).
    const double share = m.tets.share_of(q);
    b.volume_stiffness[l] = share * id.volume_modulus_kpa / b.rest_volume_mm3[l];
    b.guard_stiffness[l] = share * id.guard_modulus_kpa / b.rest_volume_mm3[l];
  }
}

void CoupledTets::pass(Solver& s, const Eigen::MatrixX3d& xm, bool linearise, int threads,
                       const Eigen::MatrixX3d* product_of) {
  TetTerm& tt = s.tets;
  const ConstCols x(xm);
  for_slices(static_cast<int64_t>(s.active_tets.size()), threads,
             [&](int64_t begin, int64_t end, int) {
               for (int64_t q = begin; q < end; ++q) {
                 const auto k = static_cast<size_t>(s.active_tets[q]);
                 Lanes p[12], f[12], d[12];
                 load_corners(tt.block[k], x, p);
                 block_forces(tt.block[k], p, f, linearise ? &tt.linear[k] : nullptr, d);
                 store_rows(f, tt.force.data() + 12 * L * k);
                 if (!linearise) continue;
                 store_rows(d, tt.diag.data() + 12 * L * k);
                 if (!product_of) continue;
                 // The first CG product while the block's constants are in cache.
                 load_corners(tt.block[k], ConstCols(*product_of), p);
                 block_product(tt.block[k], tt.linear[k], p, f);
                 store_rows(f, tt.product.data() + 12 * L * k);
               }
             });
}

void CoupledTets::product_pass(Solver& s, const Eigen::MatrixX3d& pm, int threads) {
  TetTerm& tt = s.tets;
  const ConstCols p(pm);
  for_slices(static_cast<int64_t>(s.active_tets.size()), threads,
             [&](int64_t begin, int64_t end, int) {
               for (int64_t q = begin; q < end; ++q) {
                 const auto k = static_cast<size_t>(s.active_tets[q]);
                 Lanes pc[12], y[12];
                 load_corners(tt.block[k], p, pc);
                 block_product(tt.block[k], tt.linear[k], pc, y);
                 store_rows(y, tt.product.data() + 12 * L * k);
               }
             });
}

void CoupledTets::block_stiffness(const Solver& s, size_t k, double out[16][9][kTetLanes]) {
  Lanes o[16][9];
  linear_block_stiffness(s.tets.block[k], s.tets.linear[k], o);
  for (int e = 0; e < 16; ++e)
    for (int v = 0; v < 9; ++v) store(o[e][v], out[e][v]);
}

Eigen::Matrix<double, 1, 12> CoupledTets::corner_forces(const Solver& s, const Eigen::MatrixX3d& xm,
                                                        int64_t t) {
  const TetBlock& b = s.tets.block[static_cast<size_t>(t / L)];
  Lanes p[12], f[12];
  load_corners(b, ConstCols(xm), p);
  block_forces(b, p, f, nullptr, nullptr);
  Eigen::Matrix<double, 1, 12> out;
  for (int v = 0; v < 12; ++v) out[v] = f[v][t % L];
  return out;
}

void CoupledTets::forces(Solver& s, const Eigen::MatrixX3d& xm, Eigen::MatrixX3d& f) {
  const ConstCols x(xm);
  for (const TetBlock& b : s.tets.block) {
    Lanes p[12], fc[12];
    load_corners(b, x, p);
    block_forces(b, p, fc, nullptr, nullptr);
    for (int c = 0; c < 4; ++c)
      for (int l = 0; l < L; ++l)
        for (int d = 0; d < 3; ++d) f(b.node[c][l], d) += fc[3 * c + d][l];
  }
}

double CoupledTets::energy_mj(const Solver& s, const Eigen::MatrixX3d& xm) {
  const ConstCols x(xm);
  double e = 0.0;
  for (const TetBlock& b : s.tets.block) {
    Lanes p[12], t[6];
    load_corners(b, x, p);
    EdgeParts edges;
    edge_parts(b, p, edges);
    VolumeParts vol;
    volume_parts(b, p, vol);
    Lanes q[21];
    load_q(b, q);
    multiply_q(q, edges.stretch, t);
    for (int l = 0; l < L; ++l) {
      const double dv = vol.volume[l] - b.rest_volume_mm3[l];
      const double guard = std::max(0.0, kGuardFraction * b.rest_volume_mm3[l] - vol.volume[l]);
      // kPa mm^3 = N/m mm^2 = 1e-6 J
      e += 0.5 * (b.volume_stiffness[l] * dv * dv + b.guard_stiffness[l] * guard * guard);
      for (int k = 0; k < 6; ++k) e += 0.5 * edges.stretch[k][l] * t[k][l];
    }
  }
  return e;
}

void CoupledTets::add_stiffness_rows(const Solver& s, std::vector<double>& row) {
  const ConstCols x(s.model->X);
  // Gershgorin row by row: each node's three scalar rows are summed apart and the largest
  // taken at the end (summing each tetrahedron's largest, or bounding a unit vector's entries by
  // 1 and its 1-norm by sqrt 3, as before, gave a limit about 1.3x lower).
  std::vector<std::array<double, 3>> r3(row.size(), {0.0, 0.0, 0.0});
  for (const TetBlock& b : s.tets.block) {
    Lanes p[12];
    load_corners(b, x, p);
    VolumeParts vol;
    volume_parts(b, p, vol);
    EdgeParts edges;
    edge_parts(b, p, edges);
    for (int l = 0; l < L; ++l) {
      // Volume: row (a, i) of k g g^T sums to k |g_ai| sum_v |g_v|.
      double l1 = 0.0;
      for (int v = 0; v < 12; ++v) l1 += std::abs(vol.g[v][l]);
      for (int c = 0; c < 4; ++c)
        for (int i = 0; i < 3; ++i)
          r3[b.node[c][l]][i] += b.volume_stiffness[l] * std::abs(vol.g[3 * c + i][l]) * l1;
      // Springs and coupling, J^T Q J with J's rows +-w_k at edge k's two ends: row (a, i) sums
      // to at most 2 sum over a's edges k of |w_k,i| sum_m |Q_km| |w_m|_1 (the 2: edge m's two
      // ends).
      double w1[6];
      for (int m = 0; m < 6; ++m)
        w1[m] =
            std::abs(edges.w[m][0][l]) + std::abs(edges.w[m][1][l]) + std::abs(edges.w[m][2][l]);
      for (int k = 0; k < 6; ++k) {
        double qsum = 0.0;
        for (int m = 0; m < 6; ++m) qsum += std::abs(b.q[qi(k, m)][l]) * w1[m];
        for (int end = 0; end < 2; ++end)
          for (int i = 0; i < 3; ++i)
            r3[b.node[kTetEdge[k][end]][l]][i] += 2.0 * std::abs(edges.w[k][i][l]) * qsum;
      }
    }
  }
  // Unused lanes point at node 0 with zero stiffness: they add nothing.
  for (size_t n = 0; n < row.size(); ++n) row[n] += std::max({r3[n][0], r3[n][1], r3[n][2]});
}

namespace {

// One lane's 12 x 12 stiffness at rest: the volume term (k_v / V0) g g^T (its curvature part
// vanishes at V = V0), and the springs and coupling K = J^T Q J, J_k being -w_k at corner a and
// +w_k at corner b (at rest the edges are at their rest lengths: no geometric term).
void rest_element(const TetBlock& b, const VolumeParts& vol, const Eigen::MatrixX3d& X, int l,
                  Eigen::Matrix<double, 12, 12>& k12) {
  Eigen::Matrix<double, 12, 1> g;
  for (int e = 0; e < 12; ++e) g[e] = vol.g[e][l];
  k12.noalias() = b.volume_stiffness[l] * g * g.transpose();
  Eigen::Matrix<double, 6, 12> J = Eigen::Matrix<double, 6, 12>::Zero();
  for (int k = 0; k < 6; ++k) {
    const Eigen::RowVector3d w =
        (X.row(b.node[kTetEdge[k][1]][l]) - X.row(b.node[kTetEdge[k][0]][l])).normalized();
    J.block<1, 3>(k, 3 * kTetEdge[k][0]) = -w;
    J.block<1, 3>(k, 3 * kTetEdge[k][1]) = w;
  }
  Eigen::Matrix<double, 6, 6> Q;
  for (int k = 0; k < 6; ++k)
    for (int m = 0; m < 6; ++m) Q(k, m) = b.q[qi(k, m)][l];
  k12.noalias() += J.transpose() * Q * J;
}

// Each used lane of every block with a corner `owned(node)` accepts, its 12 x 12 stiffness at
// rest handed to add(k12, corner, t) in the blocks' order (t: the model's tetrahedron).
template <class Owned, class Add>
void each_rest_element(const Solver& s, Owned&& owned, Add&& add) {
  const Eigen::MatrixX3d& X = s.model->X;
  const auto nt = static_cast<int64_t>(s.model->tets.size());
  Eigen::Matrix<double, 12, 12> k12;
  for (size_t k = 0; k < s.tets.block.size(); ++k) {
    const TetBlock& b = s.tets.block[k];
    bool any = false;
    for (int c = 0; c < 4; ++c)
      for (int l = 0; l < L; ++l) any |= owned(b.node[c][l]);
    if (!any) continue;
    Lanes p[12];
    load_corners(b, ConstCols(X), p);
    VolumeParts vol;
    volume_parts(b, p, vol);
    for (int l = 0; l < L; ++l) {
      const int64_t t = static_cast<int64_t>(k) * L + l;
      if (t >= nt || b.volume_stiffness[l] == 0.0) continue;  // an unused lane
      const int32_t corner[4] = {b.node[0][l], b.node[1][l], b.node[2][l], b.node[3][l]};
      if (!owned(corner[0]) && !owned(corner[1]) && !owned(corner[2]) && !owned(corner[3]))
        continue;
      rest_element(b, vol, X, l, k12);
      add(k12, corner, t);
    }
  }
}

}  // namespace

void CoupledTets::add_rest_stiffness(const Solver& s, const std::vector<int32_t>& row_of,
                                     BlockRows& out) {
  const TetAssembly& a = s.tets.assembly;
  if (!a.on) {  // each tetrahedron's 16 blocks searched in out's rows, on one thread
    each_rest_element(
        s, [&](int32_t node) { return row_of[node] >= 0; },
        [&](const Eigen::Matrix<double, 12, 12>& k12, const int32_t corner[4], int64_t) {
          add_element_blocks(k12, corner, row_of, out);
        });
    return;
  }
  // With the assembly's table (setup_tet_assembly: each tetrahedron's 16 entries in its
  // corners' rows), out's block of every entry is found once, and each thread sums the
  // tetrahedra into the rows it owns, in the same order as one thread would (the same sums):
  // a block search per corner pair on one thread was most of the 138 ms this took at 47,685
  // nodes (docs/benchmarks.md).
  const std::vector<int32_t> block_of = table_blocks(a, row_of, out);
  const int threads = std::clamp(omp_get_max_threads(), 1, kMaxThreads);
  for_slices(out.rows, threads, [&](int64_t lo, int64_t hi, int) {
    each_rest_element(
        s,
        [&](int32_t node) {
          const int32_t r = row_of[node];
          return r >= lo && r < hi;
        },
        [&](const Eigen::Matrix<double, 12, 12>& k12, const int32_t corner[4], int64_t t) {
          add_element_rows(k12, corner, a.entry.data() + 16 * t, row_of, block_of, lo, hi, out);
        });
  });
}

}  // namespace lamina::sim::detail
