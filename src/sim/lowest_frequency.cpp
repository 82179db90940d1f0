// The lowest natural frequency of the held model, for damping given as a ratio: mass-
// proportional damping alpha = 2 zeta omega_1 damps the slowest mode at ratio zeta (and each
// faster mode n at zeta omega_1 / omega_n).
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <cmath>
#include <vector>

#include "lamina/core/error.h"
#include "lamina/sim/simulation.h"
#include "solver.h"

namespace lamina::sim {

double lowest_angular_frequency(const Simulation& sim, int32_t max_iterations) {
  const detail::Solver& s = sim.solver();
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

  // Stiffness at rest: k u u^T per spring (the rest length is the length, so no geometric
  // term), the tetrahedra's coupling and volume, support and anchors on the diagonal. The volume
  // term between layers is left out: the slowest modes of a held organ bend it, which barely
  // changes the volume of a region.
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(36 * m.springs.size() + 3 * static_cast<size_t>(n));
  const Springs& sp = m.springs;
  for (size_t e = 0; !s.tets.on && e < sp.size(); ++e) {  // else inside the tetrahedra
    const int32_t a = row[sp.i[e]], b = row[sp.j[e]];
    const Eigen::Vector3d u = (m.X.row(sp.j[e]) - m.X.row(sp.i[e])).normalized();
    const Eigen::Matrix3d k = s.springs.stiffness_n_per_m[e] * u * u.transpose();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) {
        if (a >= 0) t.emplace_back(3 * a + r, 3 * a + c, k(r, c));
        if (b >= 0) t.emplace_back(3 * b + r, 3 * b + c, k(r, c));
        if (a >= 0 && b >= 0) {
          t.emplace_back(3 * a + r, 3 * b + c, -k(r, c));
          t.emplace_back(3 * b + r, 3 * a + c, -k(r, c));
        }
      }
  }
  detail::add_tet_stiffness_triplets(s, row, t);
  for (int32_t i = 0; i < m.node_count(); ++i)
    if (row[i] >= 0)
      for (int c = 0; c < 3; ++c)
        t.emplace_back(3 * row[i] + c, 3 * row[i] + c, s.support.stiffness_n_per_m[i]);
  Eigen::SparseMatrix<double> K(3 * n, 3 * n);
  K.setFromTriplets(t.begin(), t.end());
  Eigen::VectorXd mass(3 * n);
  for (int32_t i = 0; i < m.node_count(); ++i)
    if (row[i] >= 0) mass.segment<3>(3 * row[i]).setConstant(s.mass_kg[i]);

  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(K);
  if (ldlt.info() != Eigen::Success)
    throw Error(ErrorKind::kInternal, "the stiffness matrix did not factor");
  // Inverse iteration: K y = M x converges to the slowest mode; its Rayleigh quotient is
  // omega^2. A smooth start (every node moved alike) already leans on the slow modes.
  Eigen::VectorXd x = Eigen::VectorXd::Ones(3 * n), y;
  double omega2 = 0.0;
  for (int32_t it = 0; it < max_iterations; ++it) {
    y = ldlt.solve(mass.cwiseProduct(x));
    const double norm = std::sqrt(y.dot(mass.cwiseProduct(y)));
    if (!(norm > 0.0) || !std::isfinite(norm))
      throw Error(ErrorKind::kInternal, "the lowest-frequency iteration broke down");
    x = y / norm;
    const double next = x.dot(K * x);  // x^T M x = 1
    const bool settled = std::abs(next - omega2) <= 1e-8 * next;
    omega2 = next;
    if (settled) break;
  }
  return std::sqrt(omega2);
}

}  // namespace lamina::sim
