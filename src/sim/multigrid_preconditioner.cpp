// The multigrid as implicit Euler's preconditioner (preconditioner.h): its hierarchy from the
// system at rest, (M (1 + h alpha) + h gamma) + h^2 K_rest over the movable nodes, rebuilt when
// the material, dt or the movable nodes change beyond what masking covers, and from a step's
// own system when the deformation has moved it; its finest level the step's exact linearised
// product, smoothed by l1-Jacobi on the step's assembled blocks.
#include <fmt/ranges.h>

#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "lamina/core/clock.h"
#include "lamina/core/log.h"
#include "preconditioner.h"
#include "solver.h"

namespace lamina::sim::detail {

bool multigrid_applies(const Solver& s) {
  const Preconditioner pick = s.options.preconditioner;
  if (s.active_nodes.empty() || pick == Preconditioner::kJacobi) return false;
  if (pick == Preconditioner::kMultigrid) return true;
  return s.multigrid && s.multigrid->pick == pick && s.multigrid->chosen;
}

namespace {

bool still_fits(const Solver& s, const MultigridPreconditioner& p, double h) {
  if (p.pick != s.options.preconditioner || (p.chosen && p.mg.levels.empty()) ||
      p.stiffness_version != s.stiffness_version || p.h != h || p.row_of.size() != s.mass_kg.size())
    return false;
  for (int32_t i : s.active_nodes)
    if (p.row_of[i] < 0) return false;
  return 2 * s.active_nodes.size() >= p.nodes.size();
}

// The median over the rows of A's diagonal over the inertia's (kAutoCertainRatio).
double median_stiffness_ratio(const Solver& s, const MultigridPreconditioner& p,
                              const SparseRows& A, double h) {
  const Eigen::VectorXd d = A.diagonal();
  std::vector<double> q(p.nodes.size());
  for (size_t k = 0; k < q.size(); ++k)
    q[k] = d[static_cast<Eigen::Index>(3 * k)] / inertia_diagonal(s, p.nodes[k], h);
  const auto mid = q.begin() + static_cast<std::ptrdiff_t>(q.size() / 2);
  std::nth_element(q.begin(), mid, q.end());
  return *mid;
}

}  // namespace

// kAuto's trial: Jacobi-preconditioned CG on the system at rest A, from zero, to the step's
// tolerance, on a smooth right side (every node pushed alike, as by its weight: the slow, smooth
// motion Jacobi is slow on). Returns its iterations, at most `cap`: the choice needs no more
// (at 47,685 nodes the trial ran to the step's cap of 100, half of it past the decision).
int32_t jacobi_trial(const SparseRows& A, const SolverOptions& o, int32_t cap) {
  const Eigen::VectorXd inv_diag = A.diagonal().cwiseInverse();
  Eigen::VectorXd b(A.rows());
  for (Eigen::Index k = 0; k < b.size(); ++k) b[k] = 1.0 / inv_diag[k];
  return pcg_iterations(
      A, b, o.cg_tolerance, cap,
      [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { z = inv_diag.cwiseProduct(r); });
}

bool setup_multigrid(Solver& s, double h) {
  if (s.options.preconditioner == Preconditioner::kJacobi || s.active_nodes.empty()) return false;
  if (!s.multigrid) s.multigrid = std::make_shared<MultigridPreconditioner>();
  MultigridPreconditioner& p = *s.multigrid;
  if (still_fits(s, p, h)) return p.chosen;
  const auto t0 = Clock::now();
  const auto n = static_cast<int32_t>(s.mass_kg.size());
  p.pick = s.options.preconditioner;
  p.stiffness_version = s.stiffness_version;
  p.h = h;
  p.nodes = s.active_nodes;
  p.row_of.assign(static_cast<size_t>(n), -1);
  const auto rows = static_cast<int32_t>(p.nodes.size());
  Eigen::MatrixX3d points(rows, 3);
  for (int32_t q = 0; q < rows; ++q) {
    p.row_of[p.nodes[q]] = q;
    points.row(q) = s.model->X.row(p.nodes[q]);
  }
  // The assembly's table (setup_tet_assembly, 3 ms at 48k nodes) also serves the stiffness at
  // rest: its blocks found once, summed on the threads (CoupledTets::add_rest_stiffness). Left
  // set up if the multigrid is taken; kAuto's Jacobi does without it.
  const bool had_assembly = s.tets.assembly.on;
  if (s.tets.on && !had_assembly) setup_tet_assembly(s);
  const double assembly_s = seconds_since(t0);
  // h^2 K_rest plus the inertia on the diagonal, written into the springs' pattern; the
  // pattern stays for the rebuilds from a step's system (assembled_system()).
  rest_stiffness_blocks(s, p.row_of, rows, p.system);
  const double h2 = h * h;
  for (double& v : p.system.value) v *= h2;
  for (int32_t q = 0; q < rows; ++q) {
    double* own = p.system.at(q, q);
    for (int c = 0; c < 3; ++c) own[4 * c] += inertia_diagonal(s, p.nodes[q], h);
  }
  SparseRows A = to_sparse(p.system);
  const double system_s = seconds_since(t0);
  p.chosen = true;
  if (p.pick == Preconditioner::kAuto) {
    const int32_t decisive = std::min(kAutoTrialIterations, s.options.cg_max_iterations);
    p.stiffness_ratio = median_stiffness_ratio(s, p, A, h);
    if (p.stiffness_ratio >= kAutoCertainRatio) {
      p.trial_iterations = -1;
      log::info(
          "implicit Euler: the multigrid (the stiffness outweighs the inertia {:.0f}x on the "
          "diagonal: Jacobi would take {} iterations or more)",
          p.stiffness_ratio, static_cast<int>(4.8 * std::sqrt(p.stiffness_ratio)));
    } else {
      p.trial_iterations = jacobi_trial(A, s.options, decisive);
      p.chosen = p.trial_iterations >= decisive;
      log::info("implicit Euler: Jacobi's trial solve took {}{} iterations: {}", p.trial_iterations,
                p.chosen ? " or more" : "", p.chosen ? "the multigrid" : "Jacobi");
    }
    if (!p.chosen) {
      p.mg.levels.clear();  // nothing of a hierarchy this run will not use
      p.system = {};
      if (!had_assembly) s.tets.assembly = {};
      return false;
    }
  }
  // A V-cycle's products stream the assembled blocks of the tetrahedra (TetAssembly, set up
  // above): three products an iteration repay the assembly at any size.
  // The finest level's smoother is the step's own (refresh_multigrid(): l1-Jacobi or a weight
  // from the tracked rho): the hierarchy does not estimate one. Its power iteration, 15 products
  // of the finest matrix, was 28 ms of a 213 ms build at 47,685 nodes (docs/benchmarks.md).
  p.mg.caller_smooths = true;
  build_multigrid(std::move(A), points, p.mg);
  const MultigridShape& shape = p.mg.shape;
  log::info(
      "implicit Euler: multigrid of {} levels ({} unknowns), operator complexity {:.2f}, "
      "built in {:.2f} s",
      shape.unknowns.size(), fmt::join(shape.unknowns, " > "), shape.operator_complexity,
      shape.setup_s);
  log::debug(
      "implicit Euler: multigrid setup {:.3f} s: the assembly's pattern {:.3f}, the system at "
      "rest {:.3f}, the hierarchy {:.3f}",
      seconds_since(t0), assembly_s, system_s - assembly_s, shape.setup_s);
  p.rho = 0.0;  // the power iteration starts over
  ++p.builds;
  for (Eigen::VectorXd* v : {&p.inv_diag, &p.mask, &p.r, &p.z, &p.work}) v->setZero(3 * rows);
  p.in.setZero(n, 3);
  p.out.setZero(n, 3);
  return true;
}

namespace {

// y = A z on the rows, held nodes masked (A: the step's linearised system).
void masked_product(Solver& s, MultigridPreconditioner& p, double h, int threads,
                    const Eigen::VectorXd& z, Eigen::VectorXd& y) {
  const auto rows = static_cast<int32_t>(p.nodes.size());
  for (int32_t q = 0; q < rows; ++q)
    for (int c = 0; c < 3; ++c) p.in(p.nodes[q], c) = p.mask[3 * q + c] * z[3 * q + c];
  system_product(s, h, p.in, p.out, threads);
  for (int32_t q = 0; q < rows; ++q)
    for (int c = 0; c < 3; ++c) y[3 * q + c] = p.mask[3 * q + c] * p.out(p.nodes[q], c);
}

// The step's system over the rows as one sparse matrix, from the tetrahedra's assembled blocks
// (TetAssembly, current): M (1 + h alpha) + h gamma + h^2 (K + support), written into the
// springs' pattern that setup_multigrid() left in p.system. As rest_stiffness(), without the
// volume term between layers.
SparseRows assembled_system(const Solver& s, MultigridPreconditioner& p, double h) {
  const TetAssembly& a = s.tets.assembly;
  const auto rows = static_cast<int32_t>(p.nodes.size());
  const double h2 = h * h;
  BlockRows& A = p.system;
  std::fill(A.value.begin(), A.value.end(), 0.0);
  for (int32_t q = 0; q < rows; ++q) {
    const int32_t i = p.nodes[q];
    const double own = inertia_diagonal(s, i, h) + h2 * s.support.stiffness_n_per_m[i];
    double* diagonal = A.at(q, q);
    for (int c = 0; c < 3; ++c) diagonal[4 * c] += own;
    for (int32_t e = a.offsets[i]; e < a.offsets[i + 1]; ++e) {
      const int32_t j = p.row_of[a.column[e]];
      if (j < 0) continue;
      double* block = A.at(q, j);
      for (int k = 0; k < 9; ++k) block[k] += h2 * static_cast<double>(a.block[9 * e + k]);
    }
  }
  return to_sparse(A);
}

// rho(D^-1 A) of the step's system by power iteration on p.power. The largest eigenvalue moves
// little from step to step, so kPowerSteps products from the last step's vector track it; after
// a build the vector starts over and takes more. Approaches rho from below.
double track_rho(Solver& s, MultigridPreconditioner& p, double h, int threads) {
  const auto rows = static_cast<int32_t>(p.nodes.size());
  int steps = kPowerSteps;
  if (p.power.size() != 3 * rows || p.rho == 0.0) {
    p.power.resize(3 * rows);
    power_iteration_start(p.power);
    steps = kPowerStepsAfterBuild;
  }
  p.power = p.power.cwiseProduct(p.mask);
  double rho = 0.0;
  for (int k = 0; k < steps; ++k) {
    const double norm = p.power.norm();
    if (!(norm > 0.0)) break;
    p.power /= norm;
    masked_product(s, p, h, threads, p.power, p.work);
    for (int32_t q = 0; q < rows; ++q)
      for (int c = 0; c < 3; ++c) p.power[3 * q + c] = p.work[3 * q + c] / s.diag(p.nodes[q], c);
    rho = p.power.norm();
  }
  return rho > 0.0 && std::isfinite(rho) ? rho : p.rho;
}

}  // namespace

void refresh_multigrid(Solver& s, double h, int threads) {
  MultigridPreconditioner& p = *s.multigrid;
  const auto rows = static_cast<int32_t>(p.nodes.size());
  for (int32_t q = 0; q < rows; ++q) {
    const bool moves = s.movable[p.nodes[q]] != 0;
    for (int c = 0; c < 3; ++c) p.mask[3 * q + c] = moves ? 1.0 : 0.0;
  }
  TetAssembly& assembly = s.tets.assembly;
  if (assembly.on && !assembly.current) {
    assemble_tets(s, threads);
    assembly.current = true;
  }
  // The coarse levels follow the linearisation: when rho(D^-1 A) has moved by more than
  // kRelineariseAt either way since the hierarchy was built, the organ's deformation (rotated,
  // stretched, compressed tetrahedra) has moved its slow modes away from those the coarse
  // operators were projected from, and the coarse operators are projected again from the step's
  // own matrix (the aggregates and prolongations kept: rebuild_operators()).
  // On the SOFA liver at 5,000 skin vertices under the default poke, rho went from 3.4 at rest
  // to 10.8, and CG with the rest hierarchy ended every step at its cap of 100 iterations; with
  // two rebuilds on the way, it took 25-64 (docs/benchmarks.md).
  const double built = p.rho;
  p.rho = track_rho(s, p, h, threads);
  if (built == 0.0) p.rho_built = p.rho;
  if (assembly.on && p.rho > 0.0 &&
      (p.rho > kRelineariseAt * p.rho_built || kRelineariseAt * p.rho < p.rho_built)) {
    rebuild_operators(assembled_system(s, p, h), p.mg);
    log::debug(
        "implicit Euler: multigrid rebuilt from the step's system (rho {:.3g}, was {:.3g}) in "
        "{:.2f} s",
        p.rho, p.rho_built, p.mg.shape.setup_s);
    p.rho_built = p.rho;
    ++p.relinearised;
  }
  // The finest level's smoother. Where the stiffness is assembled, l1-Jacobi (Baker, Falgout,
  // Kolev & Yang 2011): each row's weight 1 / sum_j |A_ij|, the sum taken from the step's blocks.
  // D_l1 - A is positive semidefinite, so with the weight 4/3 the V-cycle is positive definite
  // whatever the deformation, and a row whose rotated tetrahedra couple it strongly to its
  // neighbours takes a short step without shortening everyone's. Otherwise (springs, no
  // assembly) damped Jacobi with 4 / (3 rho), rho this step's.
  if (assembly.on) {
    const double h2 = h * h;
    for (int32_t q = 0; q < rows; ++q) {
      const int32_t i = p.nodes[q];
      for (int r = 0; r < 3; ++r) {
        double sum = s.diag(i, r);  // the own entry, with mass, damping, support, volume term
        for (int32_t e = assembly.offsets[i]; e < assembly.offsets[i + 1]; ++e)
          for (int c = 0; c < 3; ++c)
            if (e != assembly.offsets[i] || c != r)
              sum += h2 * std::abs(static_cast<double>(assembly.block[9 * e + 3 * r + c]));
        p.inv_diag[3 * q + r] = p.mask[3 * q + r] / sum;
      }
    }
    p.omega = 4.0 / 3.0;
  } else {
    for (int32_t q = 0; q < rows; ++q)
      for (int c = 0; c < 3; ++c) p.inv_diag[3 * q + c] = p.mask[3 * q + c] / s.diag(p.nodes[q], c);
    p.omega = 4.0 / (3.0 * p.rho);
  }
}

double apply_multigrid(Solver& s, double h, int threads) {
  MultigridPreconditioner& p = *s.multigrid;
  const auto rows = static_cast<int32_t>(p.nodes.size());
  for (int32_t q = 0; q < rows; ++q)
    for (int c = 0; c < 3; ++c) p.r[3 * q + c] = p.mask[3 * q + c] * s.r(p.nodes[q], c);
  const auto product = [&](const Eigen::VectorXd& z, Eigen::VectorXd& y) {
    masked_product(s, p, h, threads, z, y);
  };
  p.mg.threads = threads;
  v_cycle_with(p.mg, p.r, p.inv_diag, p.omega, p.mask, product, p.z, p.work);
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
