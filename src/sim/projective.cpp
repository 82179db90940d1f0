// Projective dynamics for mass-spring systems: the "fast mass-spring" method of Liu, Bargteil,
// O'Brien and Kavan (2013). Backward Euler's nonlinear system,
//   (M + h gamma + h^2 L) x1 = M (x0 + h v0) + h gamma x0 + h^2 (J d + f_ext + M g + support X),
// is solved by alternating a local step (each spring's vector projected to its rest length,
// d_e = L_e (x_i - x_j) / |x_i - x_j|) and a global step (one solve with the constant matrix,
// factored once by Eigen's sparse LDLT and reused while dt, the material and the movable nodes
// stay the same). Held nodes are boundary values: their springs' pull enters the right side.
#include <Eigen/Cholesky>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <chrono>
#include <vector>

#include "lamina/core/error.h"
#include "solver.h"

namespace lamina::sim::detail {

struct ProjectiveSolver {
  uint64_t version = 0;  ///< Simulation::setup_version it was factored for
  double h = 0.0;
  bool factored = false;
  std::vector<int32_t> row_of;  ///< node -> unknown, -1 for a node that does not move
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  Eigen::MatrixX3d base, rhs, sol;  ///< per unknown
  Eigen::MatrixX3d d;               ///< per spring: its projected (rest-length) vector x_i - x_j
  // The volume term, linearised at the step's start (see add_volume_term).
  std::vector<Eigen::MatrixX3d> G;  ///< per region: the gradient of its volume, per unknown
  std::vector<Eigen::MatrixX3d> Z;  ///< per region: A^-1 G
  Eigen::LDLT<Eigen::MatrixXd> S;   ///< Woodbury's capacitance C^-1 + G^T A^-1 G
};

namespace {

void factor(const Solver& s, ProjectiveSolver& p, double h) {
  const Model& m = *s.model;
  const auto n = static_cast<Eigen::Index>(s.active_nodes.size());
  p.row_of.assign(static_cast<size_t>(m.node_count()), -1);
  for (Eigen::Index q = 0; q < n; ++q) p.row_of[s.active_nodes[q]] = static_cast<int32_t>(q);
  const double h2 = h * h;
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(static_cast<size_t>(n) + s.springs.adj_other.size());
  for (Eigen::Index q = 0; q < n; ++q) {
    const int32_t i = s.active_nodes[q];
    double diag = inertia_diagonal(s, i, h) + h2 * s.support.stiffness_n_per_m[i];
    for (int32_t a = s.springs.adj_offsets[i]; a < s.springs.adj_offsets[i + 1]; ++a) {
      const double k = s.springs.stiffness_n_per_m[s.springs.adj_spring[a]];
      diag += h2 * k;
      const int32_t r = p.row_of[s.springs.adj_other[a]];
      if (r >= 0) t.emplace_back(q, r, -h2 * k);
    }
    t.emplace_back(q, q, diag);
  }
  Eigen::SparseMatrix<double> A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  p.ldlt.compute(A);
  if (p.ldlt.info() != Eigen::Success)
    throw Error(ErrorKind::kInternal, "projective dynamics: the system matrix did not factor");
  p.base.resize(n, 3);
  p.rhs.resize(n, 3);
  p.sol.resize(n, 3);
  p.d.resize(static_cast<Eigen::Index>(m.springs.size()), 3);
  p.version = s.setup_version;
  p.h = h;
  p.factored = true;
}

// The volume term enters the global step implicitly, linearised at the step's start x0: its
// energy ~ E(x0) + grad E . (x - x0) + 1/2 (x - x0)^T H (x - x0), with H = sum over regions of
// c_r G_r G_r^T (c_r = K_v / V0_r, G_r the gradient of region r's volume; the Gauss-Newton part,
// as implicit Euler's). It adds h^2 (H x0 - grad E) to the right side and h^2 H to the matrix.
// The prefactored A cannot hold H (dense, and it moves with x), but H has rank = the number of
// regions, so the Sherman-Morrison-Woodbury identity solves (A + G C G^T) x = r from A's
// factor: x = A^-1 r - Z S^-1 G^T A^-1 r, Z = A^-1 G, S = C^-1 + G^T Z (regions x regions).
// Explicit pressure alone made a 30% indentation at dt = 0.1 s blow up (the stability suite).
// Expects update_volume_term() at x0 done (the gradients) and -grad E(x0) in p.base.
void add_volume_term(const Solver& s, const Eigen::MatrixX3d& x, ProjectiveSolver& p, double h) {
  const Model& m = *s.model;
  const auto n = static_cast<Eigen::Index>(s.active_nodes.size());
  const size_t regions = m.layers.size();
  p.G.resize(regions);
  p.Z.resize(regions);
  for (Eigen::MatrixX3d& g : p.G) g.setZero(n, 3);
  // Node i of layer k bounds region k from outside (+) and region k - 1 from inside (-).
  for (Eigen::Index q = 0; q < n; ++q) {
    const int32_t i = s.active_nodes[q], k = m.layer_of[i];
    if (k < 0) continue;  // interior nodes bound no region
    p.G[k].row(q) += s.volume.gradient.row(i);
    if (k > 0) p.G[k - 1].row(q) -= s.volume.gradient.row(i);
  }
  const auto r = static_cast<Eigen::Index>(regions);
  Eigen::MatrixXd S = Eigen::MatrixXd::Zero(r, r);
  const double h2 = h * h;
  for (Eigen::Index a = 0; a < r; ++a) {
    const double c = region_stiffness(s, static_cast<size_t>(a));  // K_v / V0, kPa / mm^3
    p.Z[a] = p.ldlt.solve(p.G[a]);
    // h^2 c G (G^T x0): the Gauss-Newton term's share of the right side.
    double g_x0 = 0.0;
    for (Eigen::Index q = 0; q < n; ++q) g_x0 += p.G[a].row(q).dot(x.row(s.active_nodes[q]));
    p.base += (h2 * c * g_x0) * p.G[a];
    S(a, a) = 1.0 / (h2 * c);
  }
  for (Eigen::Index a = 0; a < r; ++a)
    for (Eigen::Index b = 0; b < r; ++b) S(a, b) += p.G[a].cwiseProduct(p.Z[b]).sum();
  p.S.compute(S);
}

// x = A^-1 r already in p.sol: the Woodbury correction for the volume term's h^2 H.
void correct_for_volume_term(ProjectiveSolver& p) {
  const auto r = static_cast<Eigen::Index>(p.G.size());
  Eigen::VectorXd w(r);
  for (Eigen::Index a = 0; a < r; ++a) w[a] = p.G[a].cwiseProduct(p.sol).sum();
  const Eigen::VectorXd y = p.S.solve(w);
  for (Eigen::Index b = 0; b < r; ++b) p.sol -= y[b] * p.Z[b];
}

}  // namespace

void prepare_projective(Solver& s, double h) {
  if (!s.projective) s.projective = std::make_shared<ProjectiveSolver>();
  ProjectiveSolver& p = *s.projective;
  if (!p.factored || p.version != s.setup_version || p.h != h) factor(s, p, h);
}

Measured projective_step(Simulation& sim, double h, bool save, StepProfile& profile) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  Solver& s = sim.solver();
  prepare_projective(s, h);
  ProjectiveSolver& p = *s.projective;
  const Model& m = *s.model;
  const Springs& sp = m.springs;
  const Material& mat = s.material;
  const auto n = static_cast<int64_t>(s.active_nodes.size());
  const int T = threads_for(s);
  const double h2 = h * h;
  const bool volume = mat.volume_stiffness_kpa > 0.0;
  if (volume) update_volume_term(s, sim.x, T);  // -grad E(x0) enters base below

  // The inertial and constant parts of the right side, and the first iterate x0 + h v0.
  for_slices(n, T, [&](int64_t begin, int64_t end, int) {
    for (int64_t q = begin; q < end; ++q) {
      const int32_t i = s.active_nodes[q];
      const double mi = s.mass_kg[i];
      const double damp = h * (mat.damping_kg_per_s + mat.mass_damping_per_s * mi);
      const double jump =
          volume && m.layer_of[i] >= 0 ? s.volume.pressure_jump_kpa[m.layer_of[i]] : 0.0;
      for (int c = 0; c < 3; ++c) {
        const double predicted = sim.x(i, c) + h * sim.v(i, c);
        const double pressure = volume ? -jump * s.volume.gradient(i, c) : 0.0;
        p.base(q, c) = mi * predicted + damp * sim.x(i, c) +
                       h2 * (sim.f_ext(i, c) + mi * mat.gravity_mm_per_s2[c] +
                             s.support.stiffness_n_per_m[i] * m.X(i, c) + pressure);
        p.sol(q, c) = predicted;
      }
    }
  });
  if (volume) add_volume_term(s, sim.x, p, h);
  const auto t1 = Clock::now();  // the right side's constant part and the factor are ready
  profile.forces_us += std::chrono::duration<double, std::micro>(t1 - t0).count();
  auto position = [&](int32_t node, int c) {
    const int32_t r = p.row_of[node];
    return r >= 0 ? p.sol(r, c) : sim.x(node, c);
  };
  const auto springs = static_cast<int64_t>(s.active_springs.size());
  for (int32_t it = 0; it < s.options.projective_iterations; ++it) {
    // Local: each spring's vector at its rest length, along its current direction (along its
    // rest direction if it has collapsed to a point).
    for_slices(springs, T, [&](int64_t begin, int64_t end, int) {
      for (int64_t q = begin; q < end; ++q) {
        const int32_t e = s.active_springs[q], a = sp.i[e], b = sp.j[e];
        Eigen::Vector3d v(position(a, 0) - position(b, 0), position(a, 1) - position(b, 1),
                          position(a, 2) - position(b, 2));
        double l = v.norm();
        if (!(l > 1e-12)) {
          v = (m.X.row(a) - m.X.row(b)).transpose();
          l = v.norm();
        }
        p.d.row(e) = (sp.rest_length_mm[e] / l) * v.transpose();
      }
    });
    // Global: rhs = base + h^2 (J d + pull of held neighbours), then one prefactored solve.
    for_slices(n, T, [&](int64_t begin, int64_t end, int) {
      for (int64_t q = begin; q < end; ++q) {
        const int32_t i = s.active_nodes[q];
        double r[3] = {p.base(q, 0), p.base(q, 1), p.base(q, 2)};
        for (int32_t a = s.springs.adj_offsets[i]; a < s.springs.adj_offsets[i + 1]; ++a) {
          const int32_t c = s.springs.adj_signed[a], e = spring_of(c), j = s.springs.adj_other[a];
          const double k = s.springs.stiffness_n_per_m[e], sign = end_sign(c);
          const bool held = p.row_of[j] < 0;
          for (int ax = 0; ax < 3; ++ax)
            r[ax] += h2 * k * (sign * p.d(e, ax) + (held ? sim.x(j, ax) : 0.0));
        }
        for (int ax = 0; ax < 3; ++ax) p.rhs(q, ax) = r[ax];
      }
    });
    p.sol = p.ldlt.solve(p.rhs);
    if (volume) correct_for_volume_term(p);
  }

  // The new velocity (x1 - x0) / h; each node's end of step as the other integrators'.
  NodeState state(sim, s);
  Partials part;
  for_slices(n, T, [&](int64_t begin, int64_t end, int t) {
    Partial acc;
    for (int64_t q = begin; q < end; ++q) {
      const int32_t i = s.active_nodes[q];
      finish_node(s, state, i, h, save, (p.sol(q, 0) - sim.x(i, 0)) / h,
                  (p.sol(q, 1) - sim.x(i, 1)) / h, (p.sol(q, 2) - sim.x(i, 2)) / h, acc);
    }
    part[t] = acc;
  });
  profile.integrate_us += std::chrono::duration<double, std::micro>(Clock::now() - t1).count();
  return combine(part, T);
}

}  // namespace lamina::sim::detail
