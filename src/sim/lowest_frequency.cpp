// The lowest natural frequency of the held model, for damping given as a ratio: mass-
// proportional damping alpha = 2 zeta omega_1 damps the slowest mode at ratio zeta (and each
// faster mode n at zeta omega_1 / omega_n).
#include <Eigen/Eigenvalues>
#include <Eigen/SparseCore>
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

double lowest_angular_frequency(const Simulation& sim, int32_t max_iterations) {
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
  bool have_p = false;
  int32_t it = 0;
  for (; it < max_iterations; ++it) {
    r = kx - omega2 * mass.cwiseProduct(x);
    if (!std::isfinite(r.squaredNorm()))
      throw Error(ErrorKind::kInternal, "the lowest-frequency iteration broke down");
    // |r|_M^-1 relative to omega^2 |x|_M: the eigenvalue's error is about its square. Once that
    // is 1e-2, omega^2 (which LOBPCG lowers monotonically) moving by less than 1e-8 of itself
    // in an iteration is converged too: at 47,685 nodes omega was then within 1e-8 of its value
    // at 1e-7, in 45 iterations instead of 105; the damping needs far fewer digits.
    const double residual = std::sqrt(r.dot(r.cwiseQuotient(mass))) / omega2;
    if (residual <= 1e-7 || (residual <= 1e-2 && previous - omega2 <= 1e-8 * omega2)) break;
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
