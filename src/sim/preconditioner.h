#pragma once
// The implicit step's preconditioners (internal to module sim). Each has three parts: setup when
// the model, the movable nodes or dt change; refresh when the linearisation changes (every step:
// both take the system's diagonal, which the residual pass gathers from the force terms into
// Solver::diag); apply, z = B r. implicit_euler.cpp is a template over them, so the choice costs
// a branch per step, not per node:
// - Jacobi, B = diag(A)^-1, pointwise: fused into the passes that produce r, no pass of its own.
//   Its iterations grow with the mesh (68.9 a step on a 22k-node liver at dt = 10 ms).
// - Multigrid (multigrid.h), a V-cycle whose finest level is the exact linearised system and
//   whose coarser levels are built once from the system at rest: 2-6x fewer iterations than
//   Jacobi, for two more products and the coarse levels a cycle (docs/benchmarks.md). Its
//   iterations still grow with the mesh (2.8, 14.2, 41.7 a step at 2k, 22k, 48k nodes, 10 ms).
#include <Eigen/Core>
#include <cstdint>
#include <memory>

#include "multigrid.h"

namespace lamina::sim::detail {

struct Solver;

struct JacobiPreconditioner {
  static constexpr bool kPointwise = true;
  static double apply(double r, double diagonal) { return r / diagonal; }
};

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
  std::vector<int32_t> nodes;   ///< per row: its node
  std::vector<int32_t> row_of;  ///< per node: its row, or -1
  // Per unknown (3 row + axis): the finest level's 1 / diagonal (0 on a held node's), 1 or 0 as
  // the node moves now, the residual, the result and scratch.
  Eigen::VectorXd inv_diag, mask, r, z, work;
  Eigen::MatrixX3d in, out;  ///< per node: system_product()'s argument and result
  int64_t builds = 0;        ///< hierarchies built so far
};

/// Whether this step takes the multigrid (SolverOptions::preconditioner; kAuto is Jacobi for
/// now, multigrid_preconditioner.cpp says why).
bool multigrid_applies(const Solver& s);
/// Builds the hierarchy when the movable nodes, the material or h changed since the last build.
void setup_multigrid(Solver& s, double h);
/// The finest level's diagonal from Solver::diag (after the residual pass).
void refresh_multigrid(Solver& s);
/// s.z = B s.r on the movable nodes (rows of the others untouched); returns r . z.
double apply_multigrid(Solver& s, double h, int threads);

}  // namespace lamina::sim::detail
