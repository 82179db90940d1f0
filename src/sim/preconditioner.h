#pragma once
// The implicit step's preconditioners (internal to module sim). Each has three parts: setup when
// the model, the movable nodes or dt change; refresh when the linearisation changes (every step:
// both take the system's diagonal, which the residual pass gathers from the force terms into
// Solver::diag); apply, z = B r. implicit_euler.cpp is a template over them, so the choice costs
// a branch per step, not per node:
// - Jacobi, B = diag(A)^-1, pointwise: fused into the passes that produce r, no pass of its own.
//   Its iterations grow with the mesh (68.9 a step on a 22k-node liver at dt = 10 ms).
// - Multigrid (multigrid.h), a V-cycle whose finest level is the exact linearised system and
//   whose coarser levels are built from the system at rest, and again from a step's system when
//   the deformation has moved it (refresh_multigrid): 3-6x fewer iterations than Jacobi, for two
//   more products and the coarse levels a cycle (docs/benchmarks.md). Its iterations still grow
//   with the mesh (3.1, 14.9, 25.9 a step at 2k, 22k, 48k nodes, 10 ms).
#include <Eigen/Core>
#include <cstdint>
#include <memory>

#include "lamina/sim/simulation.h"
#include "multigrid.h"

namespace lamina::sim::detail {

struct Solver;

struct JacobiPreconditioner {
  static constexpr bool kPointwise = true;
  static double apply(double r, double diagonal) { return r / diagonal; }
};

// Power-iteration products a step for the finest level's smoothing weight (MultigridPreconditioner
// says why), and after a hierarchy is built.
constexpr int kPowerSteps = 2;
constexpr int kPowerStepsAfterBuild = 15;
// The drift of rho(D^-1 A), either way, at which the hierarchy is built again from the step's
// system (refresh_multigrid).
constexpr double kRelineariseAt = 1.5;
// kAuto takes the multigrid when Jacobi's trial solve of the system at rest (from zero, a smooth
// right side) takes this many iterations or more, or reaches the cap. Measured on the phantom
// under the default poke (`lamina run`, median step, Jacobi against multigrid): trial 25 (2,321
// nodes at 5 ms) level; 46 (2,321 nodes, 10 ms) level in a run, Jacobi 1.6x faster in the
// benchmark's held poke; 54 (3,358 nodes, 10 ms) multigrid 1.13x faster; 61, 69, 78 and 100
// (4,957 nodes at 10 ms, 2,321 at 16.7 ms, 9,871 at 10 ms and 16.7 ms) multigrid 1.6-2.8x.
constexpr int32_t kAutoTrialIterations = 50;
// ... and takes it without the trial when the trial's answer is certain: Jacobi's iterations
// grow as the square root of q, the median over the rows of the system's diagonal over the
// inertia's (1 + h^2 K_ii / m_i (1 + h alpha)): 4.8-6.3 sqrt(q) on the tetrahedral phantom from
// 618 to 47,685 nodes at 1-16.7 ms (4 iterations at q = 1.24, 46 at 54, 78 at 186, 199 at
// 1,743). From q = 300 on the trial would take 83 or more, and at 47,685 nodes and 16.7 ms
// (q = 1,743) it spent 50 products of the finest level learning it.
constexpr double kAutoCertainRatio = 300.0;

struct MultigridPreconditioner {
  static constexpr bool kPointwise = false;
  Multigrid mg;
  // What the hierarchy was built for: the material and support (Solver::stiffness_version), dt,
  // and the nodes then movable (its rows, in order). It is kept while every movable node has a
  // row and they are at least half of them: a node held since (an indenter, a grasper, a clamp)
  // is masked out of the rows instead, so holding and releasing a few nodes every step does not
  // rebuild it.
  uint64_t stiffness_version = 0;
  double h = 0.0;
  Preconditioner pick = Preconditioner::kJacobi;  ///< SolverOptions::preconditioner then
  bool chosen = false;  ///< the multigrid applies (kMultigrid, or kAuto's trial)
  /// kAuto's trial: Jacobi's iterations at rest, at most kAutoTrialIterations (-1: none)
  int32_t trial_iterations = -1;
  /// kAuto: the median of the system's diagonal over the inertia's (kAutoCertainRatio)
  double stiffness_ratio = 0.0;
  std::vector<int32_t> nodes;   ///< per row: its node
  std::vector<int32_t> row_of;  ///< per node: its row, or -1
  BlockRows system;             ///< the matrix the hierarchy was last built from, by blocks
  // Per unknown (3 row + axis): the finest level's 1 / diagonal (0 on a held node's), 1 or 0 as
  // the node moves now, the residual, the result and scratch.
  Eigen::VectorXd inv_diag, mask, r, z, work;
  Eigen::MatrixX3d in, out;  ///< per node: system_product()'s argument and result
  // The finest level's smoother follows the step's linearisation, not the rest state's: a
  // compressed liver's rotated tetrahedra raised rho(D^-1 A) from 3.4 to 10.8 (SOFA liver, 5,000
  // skin vertices), past the 1.5x margin of a weight fixed at rest, and the V-cycle stopped being
  // positive definite. rho is tracked by power iteration on `power`, a few products a step
  // (refresh_multigrid); `rho_built` is its value when the hierarchy was last built.
  Eigen::VectorXd power;
  double rho = 0.0, rho_built = 0.0;
  double omega = 0.0;        ///< the finest level's smoothing weight (with inv_diag)
  int64_t builds = 0;        ///< hierarchies built for a new dt, material or movable nodes
  int64_t relinearised = 0;  ///< hierarchies built again from a step's system (refresh_multigrid)
  int64_t fallbacks = 0;     ///< steps that found the V-cycle indefinite and took Jacobi instead
};

/// kAuto's trial: Jacobi-preconditioned CG on the system at rest `A` (setup_multigrid()), from
/// zero on a smooth right side, to o.cg_tolerance: its iterations, at most `cap`.
int32_t jacobi_trial(const SparseRows& A, const SolverOptions& o, int32_t cap);

/// Whether the steps take the multigrid (what uses_multigrid() reports): kMultigrid, or kAuto
/// once setup_multigrid() has chosen it.
bool multigrid_applies(const Solver& s);
/// Whether this step takes the multigrid: kMultigrid, or kAuto when the stiffness outweighs the
/// inertia past kAutoCertainRatio or, below it, Jacobi's trial solve of the system at rest took
/// kAutoTrialIterations or more. Decides again, and builds the
/// hierarchy, when the movable nodes, the material or h changed since.
bool setup_multigrid(Solver& s, double h);
/// After the residual pass: the finest level's smoother from the step's linearisation, and the
/// hierarchy built again from it when it has drifted (kPowerSteps products, more after a build).
void refresh_multigrid(Solver& s, double h, int threads);
/// s.z = B s.r on the movable nodes (rows of the others untouched); returns r . z, not > 0 when
/// B is not positive definite on r (the step then takes Jacobi: implicit_euler.cpp).
double apply_multigrid(Solver& s, double h, int threads);

}  // namespace lamina::sim::detail
