// The multigrid as implicit Euler's preconditioner (preconditioner.h): its hierarchy from the
// system at rest, (M (1 + h alpha) + h gamma) + h^2 K_rest over the movable nodes, rebuilt only
// when the material, dt or the movable nodes change beyond what masking covers; its finest level
// the step's exact linearised product.
#include <fmt/ranges.h>

#include <Eigen/SparseCore>
#include <algorithm>

#include "lamina/core/log.h"
#include "preconditioner.h"
#include "solver.h"

namespace lamina::sim::detail {

// kAuto is Jacobi for now: the multigrid won at 22k nodes and 10 ms (103 against 286 ms a step)
// but lost at 48k (497 against 238 ms: 41.7 iterations, and a V-cycle costs about five of
// Jacobi's), and at 1 ms Jacobi takes 1-3 iterations at any size (docs/benchmarks.md).
bool multigrid_applies(const Solver& s) {
  return s.options.preconditioner == Preconditioner::kMultigrid && !s.active_nodes.empty();
}

namespace {

bool still_fits(const Solver& s, const MultigridPreconditioner& p, double h) {
  if (p.mg.levels.empty() || p.stiffness_version != s.stiffness_version || p.h != h ||
      p.row_of.size() != s.mass_kg.size())
    return false;
  for (int32_t i : s.active_nodes)
    if (p.row_of[i] < 0) return false;
  return 2 * s.active_nodes.size() >= p.nodes.size();
}

}  // namespace

void setup_multigrid(Solver& s, double h) {
  if (!s.multigrid) s.multigrid = std::make_shared<MultigridPreconditioner>();
  MultigridPreconditioner& p = *s.multigrid;
  const auto n = static_cast<int32_t>(s.mass_kg.size());
  // A V-cycle's products stream the assembled blocks of the tetrahedra (TetAssembly): three
  // products an iteration repay the assembly at any size.
  if (s.tets.on && !s.tets.assembly.on) setup_tet_assembly(s);
  if (!still_fits(s, p, h)) {
    p.nodes = s.active_nodes;
    p.row_of.assign(static_cast<size_t>(n), -1);
    const auto rows = static_cast<int32_t>(p.nodes.size());
    Eigen::MatrixX3d points(rows, 3);
    for (int32_t q = 0; q < rows; ++q) {
      p.row_of[p.nodes[q]] = q;
      points.row(q) = s.model->X.row(p.nodes[q]);
    }
    Eigen::SparseMatrix<double> A = rest_stiffness(s, p.row_of, rows) * (h * h);
    const double damp = h * s.material.damping_kg_per_s,
                 mass_damp = h * s.material.mass_damping_per_s;
    for (int32_t q = 0; q < rows; ++q)
      for (int c = 0; c < 3; ++c)
        A.coeffRef(3 * q + c, 3 * q + c) += s.mass_kg[p.nodes[q]] * (1.0 + mass_damp) + damp;
    build_multigrid(A, points, p.mg);
    const MultigridShape& shape = p.mg.shape;
    log::info(
        "implicit Euler: multigrid of {} levels ({} unknowns), operator complexity {:.2f}, "
        "built in {:.2f} s",
        shape.unknowns.size(), fmt::join(shape.unknowns, " > "), shape.operator_complexity,
        shape.setup_s);
    p.stiffness_version = s.stiffness_version;
    p.h = h;
    ++p.builds;
    for (Eigen::VectorXd* v : {&p.inv_diag, &p.mask, &p.r, &p.z, &p.work}) v->setZero(3 * rows);
    p.in.setZero(n, 3);
    p.out.setZero(n, 3);
  }
}

void refresh_multigrid(Solver& s) {
  MultigridPreconditioner& p = *s.multigrid;
  const auto rows = static_cast<int32_t>(p.nodes.size());
  for (int32_t q = 0; q < rows; ++q) {
    const int32_t i = p.nodes[q];
    const bool moves = s.movable[i] != 0;
    for (int c = 0; c < 3; ++c) {
      p.inv_diag[3 * q + c] = moves ? 1.0 / s.diag(i, c) : 0.0;
      p.mask[3 * q + c] = moves ? 1.0 : 0.0;
    }
  }
}

double apply_multigrid(Solver& s, double h, int threads) {
  MultigridPreconditioner& p = *s.multigrid;
  const auto rows = static_cast<int32_t>(p.nodes.size());
  for (int32_t q = 0; q < rows; ++q)
    for (int c = 0; c < 3; ++c) p.r[3 * q + c] = p.mask[3 * q + c] * s.r(p.nodes[q], c);
  const auto product = [&](const Eigen::VectorXd& z, Eigen::VectorXd& y) {
    for (int32_t q = 0; q < rows; ++q)
      for (int c = 0; c < 3; ++c) p.in(p.nodes[q], c) = p.mask[3 * q + c] * z[3 * q + c];
    system_product(s, h, p.in, p.out, threads);
    for (int32_t q = 0; q < rows; ++q)
      for (int c = 0; c < 3; ++c) y[3 * q + c] = p.mask[3 * q + c] * p.out(p.nodes[q], c);
  };
  v_cycle_with(p.mg, p.r, p.inv_diag, p.mask, product, p.z, p.work);
  double rz = 0.0;
  for (int32_t q = 0; q < rows; ++q) {
    const int32_t i = p.nodes[q];
    if (!s.movable[i]) continue;
    for (int c = 0; c < 3; ++c) {
      s.z(i, c) = p.z[3 * q + c];
      rz += s.r(i, c) * p.z[3 * q + c];
    }
  }
  return rz;
}

}  // namespace lamina::sim::detail

namespace lamina::sim {

bool uses_multigrid(const Simulation& sim) {
  return detail::multigrid_applies(sim.solver());
}

}  // namespace lamina::sim
