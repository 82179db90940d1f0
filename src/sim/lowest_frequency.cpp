// The lowest natural frequency of the held model, for damping given as a ratio: mass-
// proportional damping alpha = 2 zeta omega_1 damps the slowest mode at ratio zeta (and each
// faster mode n at zeta omega_1 / omega_n).
#include <Eigen/Eigenvalues>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "lamina/core/clock.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/sim/simulation.h"
#include "multigrid.h"
#include "solver.h"

namespace lamina::sim {

double lowest_angular_frequency(const Simulation& sim, int32_t max_iterations, double tolerance) {
  using namespace detail;
  const Solver& s = sim.solver();
  const Model& m = *s.model;
  bool supported = false;
  for (double k : s.support.stiffness_n_per_m) supported = supported || k > 0.0;
  std::vector<int32_t> row(static_cast<size_t>(m.node_count()), -1);
  int32_t n = 0;
  for (int32_t i = 0; i < m.node_count(); ++i)
    if (!s.fixed[i]) row[i] = n++;
  if (n == 0) throw invalid_input("damping ratio", "every node is held: nothing can vibrate");
  if (n == m.node_count() && !supported)
    throw invalid_input("damping ratio",
                        "the model is held nowhere (no fixed nodes, no anchor springs), so its "
                        "slowest motion is a free drift; fix a region or use damping_kg_per_s");

  Eigen::VectorXd mass(3 * n);
  for (int32_t i = 0; i < m.node_count(); ++i)
    if (row[i] >= 0) mass.segment<3>(3 * row[i]).setConstant(s.mass_kg[i]);

  // LOBPCG (Knyazev 2001) for the smallest eigenpair of K x = omega^2 M x, preconditioned by a
  // multigrid V-cycle on K: its iterations do not grow with the model, and nothing the size of
  // the model is factored (an LDLT of K took 176 s at 42,823 nodes). Each iteration finds the
  // best x in span{x, T r, p} (T the V-cycle, p the last step), M-orthonormalised.
  const auto t0 = Clock::now();
  Multigrid mg;
  Eigen::MatrixX3d points(n, 3);
  for (int32_t i = 0; i < m.node_count(); ++i)
    if (row[i] >= 0) points.row(row[i]) = m.X.row(i);
  // The stiffness at rest (rest_stiffness.cpp; the volume term between layers is left out: the
  // slowest modes of a held organ bend it, which barely changes the volume of a region).
  build_multigrid(rest_stiffness(s, row, n), points, mg);
  const SparseRows& Kr = mg.levels[0].A;  // K, by rows (threaded products)
  const auto dot_m = [&](const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
    return a.dot(mass.cwiseProduct(b));
  };
  Eigen::VectorXd x = Eigen::VectorXd::Ones(3 * n);  // smooth: leans on the slow modes
  x /= std::sqrt(dot_m(x, x));
  Eigen::VectorXd kx = Kr * x, r, p, basis[3], kbasis[3];
  double omega2 = x.dot(kx), previous = std::numeric_limits<double>::infinity();
  double drops[2] = {0.0, 0.0};  // how far omega^2 fell in the last two iterations
  bool have_p = false;
  int32_t it = 0;
  for (; it < max_iterations; ++it) {
    r = kx - omega2 * mass.cwiseProduct(x);
    if (!std::isfinite(r.squaredNorm()))
      throw Error(ErrorKind::kInternal, "the lowest-frequency iteration broke down");
    const double residual = std::sqrt(r.dot(r.cwiseQuotient(mass))) / omega2;
    if (residual <= 1e-7) break;  // exact to round-off
    // LOBPCG lowers omega^2 monotonically, by about a fixed ratio rho of what is left an
    // iteration once the preconditioner sets the pace (x0.82 at 47,685 nodes): what is left is
    // then about the last fall times rho / (1 - rho). rho is the larger of the last two falls'
    // ratios, at least 1/2 and at most 0.95, so an early lull does not pass for convergence. The
    // damping needs omega to a few digits: the default 1e-4 stopped a 20k-node phantom after 26
    // iterations instead of 48 (omega within 4.5e-5 of the converged one).
    const double drop = previous - omega2;
    if (it >= 3 && drop >= 0.0 && drops[1] > 0.0) {
      const double rho = std::clamp(
          std::max(drop / drops[1], drops[0] > 0.0 ? drops[1] / drops[0] : 0.0), 0.5, 0.95);
      if (drop * rho / (1.0 - rho) <= tolerance * omega2) break;  // omega to tolerance / 2
    }
    if (std::isfinite(drop)) drops[0] = drops[1], drops[1] = drop;
    previous = omega2;
    mg.levels[0].b = r;
    v_cycle(mg, 0);
    // The subspace, M-orthonormalised by Gram-Schmidt (twice, for round-off); a direction that
    // has nothing left beyond the others is dropped.
    int k = 0;
    for (const Eigen::VectorXd* v : {&x, &mg.levels[0].x, have_p ? &p : nullptr}) {
      if (!v) continue;
      Eigen::VectorXd u = *v;
      for (int pass = 0; pass < 2; ++pass)
        for (int j = 0; j < k; ++j) u -= dot_m(basis[j], u) * basis[j];
      const double norm = std::sqrt(dot_m(u, u));
      if (!(norm > 1e-10 * std::sqrt(dot_m(*v, *v)))) continue;
      basis[k] = u / norm;
      kbasis[k] = Kr * basis[k];
      ++k;
    }
    Eigen::MatrixXd G(k, k);
    for (int a = 0; a < k; ++a)
      for (int b = 0; b < k; ++b)
        G(a, b) = 0.5 * (basis[a].dot(kbasis[b]) + basis[b].dot(kbasis[a]));
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(G);
    const Eigen::VectorXd c = eig.eigenvectors().col(0);
    Eigen::VectorXd next = c[0] * basis[0];
    kx = c[0] * kbasis[0];
    p.setZero(3 * n);
    for (int a = 1; a < k; ++a) {
      next += c[a] * basis[a];
      kx += c[a] * kbasis[a];
      p += c[a] * basis[a];  // the step taken beyond x
    }
    have_p = k > 1;
    const double norm = std::sqrt(dot_m(next, next));
    x = next / norm;
    kx /= norm;
    omega2 = x.dot(kx);
  }
  log::debug(
      "slowest vibration: {} LOBPCG iterations on {} unknowns, multigrid of {} levels, {:.2f} s",
      it, 3 * n, mg.levels.size(), seconds_since(t0));
  return std::sqrt(omega2);
}

}  // namespace lamina::sim
