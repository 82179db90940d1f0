// Stable Neo-Hookean tetrahedra (Material::tet_model kNeoHookean; docs/physics.md). Each
// tetrahedron stores, F = sum_c x_c grad_c^T its deformation gradient, J = det F, C = F^T F,
//   V0 [ mu/2 (tr C - 3) + lambda'/2 (J - alpha)^2 - mu^2 / (2 lambda') ]
// with lambda' = lambda + mu and alpha = 1 + mu / lambda' (Smith, de Goes & Kim 2018, eq. 14 with
// the Lame parameters matched to linear elasticity at small strain; the constant makes rest
// zero energy). Its first Piola stress is P = mu F + p dJ/dF, the pressure p = lambda' (J - alpha),
// so an inverted tetrahedron (J < 0) is pushed back like a compressed one. Below J = 0.1 the
// same guard as the springs' tetrahedra adds kg/2 (0.1 - J)^2 (kg = 100 (lambda + 2 mu)).
//
// The implicit step's stiffness, in F's nine entries: mu I + p' dJ/dF dJ/dF^T + q H_J, with
// p' = lambda' (+ kg under the guard) and H_J = d^2 J / dF^2. mu I and the outer product are
// positive; H_J is not (its eigenvalues are +-sigma_k and those of a 3 x 3 block whose rows sum
// to sigma_i + sigma_j, so |eig| <= 2 sigma_max). Bounding q to |q| <= mu / (2 sigma_max), with
// sigma_max^2 bounded by C's largest row sum, keeps the matrix positive semi-definite without a
// singular value decomposition per tetrahedron (which would cost more than the rest of a 1 ms
// step on the paper-size liver; docs/physics.md has the trade). Forces are exact; only the
// step's matrix is bounded, and where |p| is already under the bound it is the exact Hessian.
//
// Same layout as tet_term.cpp: blocks of kTetLanes tetrahedra, one per SIMD lane, each block
// writing its own corner rows.
#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>

#include "force_terms.h"
#include "lamina/core/error.h"
#include "solver.h"
#include "tet_lanes.h"

namespace lamina::sim::detail {

using namespace lanes_of_tets;

namespace {

constexpr double kGuardJ = 0.1;  // the guard acts below this J (tet_term.cpp's fraction of V0)

// A block's shape-function gradients: corner c (0-3), axis j at g[3 c + j].
inline void load_grads(const NeoBlock& b, Lanes g[12]) {
  for (int v = 0; v < 9; ++v) g[3 + v] = lanes(b.grad[v]);
  for (int j = 0; j < 3; ++j) g[j] = -(g[3 + j] + g[6 + j] + g[9 + j]);
}

// F (row-major) of corner values p: F_ij = sum_c p_c,i g_c,j (grad_0 carries -x_0's share).
inline void gradient_of(const Lanes g[12], const Lanes p[12], Lanes F[9]) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      Lanes sum = p[i] * g[j];
      for (int c = 1; c < 4; ++c) sum += p[3 * c + i] * g[3 * c + j];
      F[3 * i + j] = sum;
    }
}

// Column j of a row-major 3 x 3.
inline void column(const Lanes M[9], int j, Lanes v[3]) {
  v[0] = M[j], v[1] = M[3 + j], v[2] = M[6 + j];
}
inline void cross(const Lanes a[3], const Lanes b[3], Lanes out[3]) {
  out[0] = a[1] * b[2] - a[2] * b[1];
  out[1] = a[2] * b[0] - a[0] * b[2];
  out[2] = a[0] * b[1] - a[1] * b[0];
}
inline void set_column(Lanes M[9], int j, const Lanes v[3]) {
  M[j] = v[0], M[3 + j] = v[1], M[6 + j] = v[2];
}

// dJ/dF: its columns are f1 x f2, f2 x f0, f0 x f1 (f_j F's columns); and J.
inline Lanes cofactor(const Lanes F[9], Lanes cof[9]) {
  Lanes f[3][3];
  for (int j = 0; j < 3; ++j) column(F, j, f[j]);
  for (int j = 0; j < 3; ++j) {
    Lanes c[3];
    cross(f[(j + 1) % 3], f[(j + 2) % 3], c);
    set_column(cof, j, c);
  }
  return f[0][0] * cof[0] + f[0][1] * cof[3] + f[0][2] * cof[6];
}

// The directional derivative of dJ/dF along dF: column j is df_{j+1} x f_{j+2} + f_{j+1} x
// df_{j+2} (indices mod 3).
inline void cofactor_derivative(const Lanes F[9], const Lanes dF[9], Lanes out[9]) {
  Lanes f[3][3], d[3][3];
  for (int j = 0; j < 3; ++j) column(F, j, f[j]), column(dF, j, d[j]);
  for (int j = 0; j < 3; ++j) {
    const int a = (j + 1) % 3, b = (j + 2) % 3;
    Lanes u[3], w[3];
    cross(d[a], f[b], u);
    cross(f[a], d[b], w);
    for (int i = 0; i < 3; ++i) u[i] += w[i];
    set_column(out, j, u);
  }
}

// Corner values sign V0 P grad_c (corner c, axis i at out[3 c + i]): minus the forces of a
// stress P (sign -1), or the product of a stress increment (sign +1).
inline void to_corners(const Lanes g[12], const Lanes P[9], Lanes scale, Lanes out[12]) {
  for (int c = 0; c < 4; ++c)
    for (int i = 0; i < 3; ++i)
      out[3 * c + i] =
          scale * (P[3 * i] * g[3 * c] + P[3 * i + 1] * g[3 * c + 1] + P[3 * i + 2] * g[3 * c + 2]);
}

struct Moduli {
  double mu, lambda, guard, alpha;
};
inline Moduli moduli(const TetTerm& t) {
  return {t.mu_kpa, t.lambda_kpa, t.guard_kpa, 1.0 + t.mu_kpa / t.lambda_kpa};
}

// A block's corner forces at p; with lin, also its linearisation and Jacobi diagonal.
void block_forces(const NeoBlock& b, const Moduli& k, const Lanes p[12], Lanes f[12],
                  NeoBlockLinear* lin, Lanes diag[12]) {
  Lanes g[12], F[9], cof[9];
  load_grads(b, g);
  gradient_of(g, p, F);
  const Lanes J = cofactor(F, cof);
  const Lanes below = max(kGuardJ - J, Lanes{});
  const Lanes pressure = k.lambda * (J - k.alpha) - k.guard * below;
  Lanes P[9];
  for (int v = 0; v < 9; ++v) P[v] = k.mu * F[v] + pressure * cof[v];
  const Lanes v0 = lanes(b.rest_volume_mm3);
  to_corners(g, P, -v0, f);
  if (!lin) return;
  const Lanes dp_dj = below > 0.0 ? splat(k.lambda + k.guard) : splat(k.lambda);
  // sigma_max^2 <= C's largest absolute row sum (Gershgorin); the curvature's pressure bounded
  // by mu / (2 sigma_max) keeps mu I + q H_J positive semi-definite (the file's header).
  Lanes rows = Lanes{};
  for (int i = 0; i < 3; ++i) {
    Lanes row = Lanes{};
    for (int j = 0; j < 3; ++j) {
      const Lanes c = F[i] * F[j] + F[3 + i] * F[3 + j] + F[6 + i] * F[6 + j];  // C_ij
      row += c < 0.0 ? -c : c;
    }
    rows = max(rows, row);
  }
  const Lanes bound = k.mu / (2.0 * sqrt(max(rows, splat(1e-24))));
  const Lanes q = pressure > bound ? bound : (pressure < -bound ? -bound : pressure);
  for (int v = 0; v < 9; ++v) store(F[v], lin->f[v]), store(cof[v], lin->cof[v]);
  store(dp_dj, lin->volume);
  store(q, lin->curvature);
  // K's diagonal: V0 (mu |g_c|^2 + p' (cof g_c)_i^2); H_J adds nothing there (J is linear in each
  // row of F).
  for (int c = 0; c < 4; ++c) {
    const Lanes gg =
        g[3 * c] * g[3 * c] + g[3 * c + 1] * g[3 * c + 1] + g[3 * c + 2] * g[3 * c + 2];
    for (int i = 0; i < 3; ++i) {
      const Lanes cg =
          cof[3 * i] * g[3 * c] + cof[3 * i + 1] * g[3 * c + 1] + cof[3 * i + 2] * g[3 * c + 2];
      diag[3 * c + i] = v0 * (k.mu * gg + dp_dj * cg * cg);
    }
  }
}

// (K p) of a linearised block at its corners: V0 dP grad_c, dP = mu dF + p' (cof : dF) cof +
// q dcof[dF].
void block_product(const NeoBlock& b, const NeoBlockLinear& lin, double mu, const Lanes p[12],
                   Lanes y[12]) {
  Lanes g[12], dF[9], F[9], cof[9], dcof[9];
  load_grads(b, g);
  gradient_of(g, p, dF);
  for (int v = 0; v < 9; ++v) F[v] = lanes(lin.f[v]), cof[v] = lanes(lin.cof[v]);
  cofactor_derivative(F, dF, dcof);
  Lanes along = Lanes{};
  for (int v = 0; v < 9; ++v) along += cof[v] * dF[v];
  along *= lanes(lin.volume);
  const Lanes q = lanes(lin.curvature);
  Lanes dP[9];
  for (int v = 0; v < 9; ++v) dP[v] = mu * dF[v] + along * cof[v] + q * dcof[v];
  to_corners(g, dP, lanes(b.rest_volume_mm3), y);
}

// One corner pair's 3 x 3 block of K (row-major), N/m: V0 [mu (g_r . g_c) I + p' (cof g_r)
// (cof g_c)^T - q [F (g_r x g_c)]x] (the last from d^2 J / dF_aj dF_dl = e_adm e_jln F_mn).
void pair_block(const Eigen::Vector3d& gr, const Eigen::Vector3d& gc, const Eigen::Matrix3d& F,
                const Eigen::Matrix3d& cof, double mu, double dp_dj, double q, double v0,
                double* out) {
  const Eigen::Vector3d cr = cof * gr, cc = cof * gc, w = F * gr.cross(gc);
  Eigen::Matrix3d skew;
  skew << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  const Eigen::Matrix3d K =
      v0 * (mu * gr.dot(gc) * Eigen::Matrix3d::Identity() + dp_dj * cr * cc.transpose() - q * skew);
  for (int a = 0; a < 3; ++a)
    for (int d = 0; d < 3; ++d) out[3 * a + d] = K(a, d);
}

// Tetrahedron t's shape-function gradients (corner c in column c) and rest volume.
Eigen::Matrix<double, 3, 4> grads_of(const TetTerm& tt, int64_t t, double& v0) {
  const NeoBlock& b = tt.neo[static_cast<size_t>(t / L)];
  const int l = static_cast<int>(t % L);
  Eigen::Matrix<double, 3, 4> g;
  for (int c = 1; c < 4; ++c)
    for (int j = 0; j < 3; ++j) g(j, c) = b.grad[3 * (c - 1) + j][l];
  g.col(0) = -(g.col(1) + g.col(2) + g.col(3));
  v0 = b.rest_volume_mm3[l];
  return g;
}

}  // namespace

void NeoHookeanTets::setup(Solver& s) {
  TetTerm& t = s.tets;
  const Model& m = *s.model;
  const double mu = t.id->shear_modulus_kpa, lambda = t.id->lame_lambda_kpa;
  t.mu_kpa = mu;
  t.lambda_kpa = lambda + mu;
  t.guard_kpa = t.id->guard_modulus_kpa;
  t.neo.assign(t.block.size(), NeoBlock{});
  for (Eigen::Index q = 0; q < m.tets.size(); ++q) {
    Eigen::Matrix3d Dm;
    for (int c = 1; c < 4; ++c)
      Dm.col(c - 1) = (m.X.row(m.tets.T(q, c)) - m.X.row(m.tets.T(q, 0))).transpose();
    const double det = Dm.determinant();
    if (!(std::abs(det) > 0.0))
      throw invalid_input("model", "tetrahedron " + std::to_string(q) +
                                       " has no volume at rest: Neo-Hookean tissue needs every "
                                       "tetrahedron's rest shape");
    const Eigen::Matrix3d B = Dm.inverse();
    NeoBlock& b = t.neo[static_cast<size_t>(q / L)];
    const int l = static_cast<int>(q % L);
    for (int c = 0; c < 3; ++c)
      for (int j = 0; j < 3; ++j) b.grad[3 * c + j][l] = B(c, j);
    // The energy's weight: the rest volume, times a cut's copy's share of its material.
    b.rest_volume_mm3[l] = m.tets.share_of(q) * std::abs(det) / 6.0;
  }
  t.neo_linear.assign(t.block.size(), NeoBlockLinear{});
}

void NeoHookeanTets::pass(Solver& s, const Eigen::MatrixX3d& xm, bool linearise, int threads,
                          const Eigen::MatrixX3d* product_of) {
  TetTerm& tt = s.tets;
  const ConstCols x(xm);
  const Moduli k = moduli(tt);
  for_slices(static_cast<int64_t>(s.active_tets.size()), threads,
             [&](int64_t begin, int64_t end, int) {
               for (int64_t q = begin; q < end; ++q) {
                 const auto b = static_cast<size_t>(s.active_tets[q]);
                 Lanes p[12], f[12], d[12] = {};  // written only when linearising
                 load_corners(tt.block[b], x, p);
                 block_forces(tt.neo[b], k, p, f, linearise ? &tt.neo_linear[b] : nullptr, d);
                 store_rows(f, tt.force.data() + 12 * L * b);
                 if (!linearise) continue;
                 store_rows(d, tt.diag.data() + 12 * L * b);
                 if (!product_of) continue;
                 load_corners(tt.block[b], ConstCols(*product_of), p);
                 block_product(tt.neo[b], tt.neo_linear[b], k.mu, p, f);
                 store_rows(f, tt.product.data() + 12 * L * b);
               }
             });
}

void NeoHookeanTets::product_pass(Solver& s, const Eigen::MatrixX3d& pm, int threads) {
  TetTerm& tt = s.tets;
  const ConstCols p(pm);
  for_slices(static_cast<int64_t>(s.active_tets.size()), threads,
             [&](int64_t begin, int64_t end, int) {
               for (int64_t q = begin; q < end; ++q) {
                 const auto b = static_cast<size_t>(s.active_tets[q]);
                 Lanes pc[12], y[12];
                 load_corners(tt.block[b], p, pc);
                 block_product(tt.neo[b], tt.neo_linear[b], tt.mu_kpa, pc, y);
                 store_rows(y, tt.product.data() + 12 * L * b);
               }
             });
}

void NeoHookeanTets::block_stiffness(const Solver& s, size_t k, double out[16][9][kTetLanes]) {
  const TetTerm& tt = s.tets;
  const NeoBlockLinear& lin = tt.neo_linear[k];
  for (int l = 0; l < L; ++l) {
    double v0 = 0.0;
    const Eigen::Matrix<double, 3, 4> g = grads_of(tt, static_cast<int64_t>(k) * L + l, v0);
    Eigen::Matrix3d F, cof;
    for (int v = 0; v < 9; ++v) F(v / 3, v % 3) = lin.f[v][l], cof(v / 3, v % 3) = lin.cof[v][l];
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) {
        double block[9];
        pair_block(g.col(r), g.col(c), F, cof, tt.mu_kpa, lin.volume[l], lin.curvature[l], v0,
                   block);
        for (int v = 0; v < 9; ++v) out[4 * r + c][v][l] = block[v];
      }
  }
}

Eigen::Matrix<double, 12, 12> NeoHookeanTets::rest_element(const Solver& s, int64_t t) {
  // At rest F = dJ/dF = I and the pressure is exactly -mu: linear elasticity, positive
  // semi-definite as it stands (its zero modes are the rigid motions).
  const TetTerm& tt = s.tets;
  double v0 = 0.0;
  const Eigen::Matrix<double, 3, 4> g = grads_of(tt, t, v0);
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  Eigen::Matrix<double, 12, 12> K;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) {
      double block[9];
      pair_block(g.col(r), g.col(c), I, I, tt.mu_kpa, tt.lambda_kpa, -tt.mu_kpa, v0, block);
      for (int v = 0; v < 9; ++v) K(3 * r + v / 3, 3 * c + v % 3) = block[v];
    }
  return K;
}

Eigen::Matrix<double, 1, 12> NeoHookeanTets::corner_forces(const Solver& s,
                                                           const Eigen::MatrixX3d& xm, int64_t t) {
  const auto b = static_cast<size_t>(t / L);
  Lanes p[12], f[12];
  load_corners(s.tets.block[b], ConstCols(xm), p);
  block_forces(s.tets.neo[b], moduli(s.tets), p, f, nullptr, nullptr);
  Eigen::Matrix<double, 1, 12> out;
  for (int v = 0; v < 12; ++v) out[v] = f[v][t % L];
  return out;
}

void NeoHookeanTets::forces(Solver& s, const Eigen::MatrixX3d& xm, Eigen::MatrixX3d& f) {
  const ConstCols x(xm);
  const Moduli k = moduli(s.tets);
  for (size_t b = 0; b < s.tets.block.size(); ++b) {
    Lanes p[12], fc[12];
    load_corners(s.tets.block[b], x, p);
    block_forces(s.tets.neo[b], k, p, fc, nullptr, nullptr);
    for (int c = 0; c < 4; ++c)
      for (int l = 0; l < L; ++l)
        for (int d = 0; d < 3; ++d) f(s.tets.block[b].node[c][l], d) += fc[3 * c + d][l];
  }
}

double NeoHookeanTets::energy_mj(const Solver& s, const Eigen::MatrixX3d& xm) {
  const ConstCols x(xm);
  const Moduli k = moduli(s.tets);
  double e = 0.0;
  for (size_t b = 0; b < s.tets.block.size(); ++b) {
    Lanes p[12], g[12], F[9], cof[9];
    load_corners(s.tets.block[b], x, p);
    load_grads(s.tets.neo[b], g);
    gradient_of(g, p, F);
    const Lanes J = cofactor(F, cof);
    Lanes trace = Lanes{};
    for (int v = 0; v < 9; ++v) trace += F[v] * F[v];
    for (int l = 0; l < L; ++l) {
      const double v0 = s.tets.neo[b].rest_volume_mm3[l];
      const double guard = std::max(0.0, kGuardJ - J[l]);
      // kPa mm^3 = 1e-6 J
      e += v0 *
           (0.5 * k.mu * (trace[l] - 3.0) + 0.5 * k.lambda * (J[l] - k.alpha) * (J[l] - k.alpha) -
            0.5 * k.mu * k.mu / k.lambda + 0.5 * k.guard * guard * guard);
    }
  }
  return e;
}

void NeoHookeanTets::add_stiffness_rows(const Solver& s, std::vector<double>& row) {
  // Gershgorin row by row of each tetrahedron's stiffness at rest: each node's three scalar rows
  // summed apart, the largest taken at the end (as the coupled springs').
  std::vector<std::array<double, 3>> r3(row.size(), {0.0, 0.0, 0.0});
  for (Eigen::Index t = 0; t < s.model->tets.size(); ++t) {
    const Eigen::Matrix<double, 12, 1> sums = rest_element(s, t).cwiseAbs().rowwise().sum();
    for (int v = 0; v < 12; ++v) r3[s.model->tets.T(t, v / 3)][v % 3] += sums[v];
  }
  for (size_t n = 0; n < row.size(); ++n) row[n] += std::max({r3[n][0], r3[n][1], r3[n][2]});
}

void NeoHookeanTets::add_rest_stiffness(const Solver& s, const std::vector<int32_t>& row_of,
                                        BlockRows& out) {
  const TetAssembly& a = s.tets.assembly;
  const Eigen::Index nt = s.model->tets.size();
  if (!a.on) {  // each tetrahedron's blocks searched, on one thread
    for (Eigen::Index t = 0; t < nt; ++t) {
      const Eigen::Vector4i corner = s.model->tets.T.row(t).transpose();
      add_element_blocks(rest_element(s, t), corner.data(), row_of, out);
    }
    return;
  }
  // Through the assembly's table, each thread its rows (as CoupledTets::add_rest_stiffness).
  const std::vector<int32_t> block_of = table_blocks(a, row_of, out);
  const int threads = std::clamp(omp_get_max_threads(), 1, kMaxThreads);
  for_slices(out.rows, threads, [&](int64_t lo, int64_t hi, int) {
    for (Eigen::Index t = 0; t < nt; ++t) {
      const Eigen::Vector4i corner = s.model->tets.T.row(t).transpose();
      bool any = false;
      for (int c = 0; c < 4; ++c) any |= row_of[corner[c]] >= lo && row_of[corner[c]] < hi;
      if (!any) continue;
      add_element_rows(rest_element(s, t), corner.data(), a.entry.data() + 16 * t, row_of, block_of,
                       lo, hi, out);
    }
  });
}

}  // namespace lamina::sim::detail
