#pragma once
// Aggregation multigrid (after Vanek, Mandel & Brezina 1996) for the implicit step's system and
// the slowest vibration: the reference paper's multi-scale idea, the same organ at several
// resolutions, built from the matrix itself. Each level groups the nodes of the one below into
// aggregates (a node and its strong neighbours), carries the rigid motions of each aggregate
// (three translations, three rotations: what elasticity cannot resist) as that coarse node's
// unknowns, and takes the Galerkin product P^T A P as the coarse operator. The coarsest level
// (at most a few thousand unknowns) is factored once. docs/architecture.md says why this and not
// hypre, and why the prolongation is not smoothed.
//
// A V-cycle with one damped-Jacobi sweep before and after each coarse correction is a
// symmetric positive definite preconditioner for conjugate gradients. Every coarse node has six
// unknowns (an aggregate with fewer rigid motions pads the rest: zero in P, its own diagonal in
// A, never reached by a residual), so that the cycle's products below the finest level are
// float 6x6 (and 3x6) block products on the step's threads (float_blocks.h). Internal to module
// sim.
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <cmath>
#include <cstdint>
#include <vector>

#include "block_rows.h"
#include "float_blocks.h"

namespace lamina::sim::detail {

struct MultigridLevel {
  SparseRows A;     ///< this level's operator (level 0: the matrix it was built from)
  SparseRows P, R;  ///< to the next level: prolongation, and restriction R = P^T
  /// The cycle's products: A (coarse levels only: the finest is the caller's), P and R as float
  /// blocks of this level's node (3 unknowns on the finest, 6 below) by the next one's (6).
  FloatBlocks A_blocks, P_blocks, R_blocks;
  std::vector<int32_t> padding;  ///< the unknowns that pad a node to six (no rigid motion)
  int block = 3;  ///< unknowns per node: 3 on the finest and a grid level, 6 on aggregates'
  Eigen::VectorXd inv_diag;  ///< 1 / diag(A)
  double omega = 0.0;        ///< damped Jacobi's weight, 4 / (3 rho(D^-1 A))
  Eigen::VectorXd b, x, r;   ///< workspace: right side, solution, residual
};

/// What a hierarchy is (the benchmark and the run summary report it).
struct MultigridShape {
  std::vector<int64_t> unknowns, nonzeros;  ///< per level (unknowns: without the padding)
  double setup_s = 0.0;
  /// sum over levels of nonzeros / the finest level's: the V-cycle's cost in products of A
  double operator_complexity = 0.0;
};

struct Multigrid {
  std::vector<MultigridLevel> levels;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> coarsest;
  MultigridShape shape;
  int threads = 1;  ///< the cycle's products' threads (the caller's: implicit Euler sets its own)
  /// The finest level is smoothed by the caller (v_cycle_with(): its own diagonal and weight):
  /// its omega is not estimated (0), and v_cycle() must not start on it.
  bool caller_smooths = false;
};

/// Builds the hierarchy of the symmetric positive definite A: 3 unknowns per node, interleaved
/// (row 3 i + axis), `points` (#nodes by 3, mm) where the nodes are (the rigid rotations' arms).
/// Coarsens until at most `coarsest_unknowns` are left, then factors that level.
/// `smoothed`: Vanek's smoothed aggregation, each prolongation smoothed by one damped-Jacobi step
/// (P = (I - omega D^-1 A) P_tentative); the steps take the plain one (docs/benchmarks.md, issue
/// 48: the harness multigrid_harness compares them).
/// `grid_mm` > 0: the first coarse level is geometric, the corners of a regular grid of that
/// spacing over the points (the cells that hold a node), each node interpolated trilinearly from
/// its cell's corners (linear motions, the rigid ones among them, are in the coarse space); the
/// aggregation starts below it.
void build_multigrid(SparseRows A, const Eigen::MatrixX3d& points, Multigrid& mg,
                     int64_t coarsest_unknowns = 1500, bool smoothed = false, double grid_mm = 0.0);

/// The grid's coarse level of build_multigrid(): P (3 #points x 3 #corners) interpolates the
/// corners of a regular grid of spacing `grid_mm` over `points` (those of the cells that hold a
/// point) trilinearly to the points, a weight per point and corner on each axis; returns the
/// corners' positions (#corners x 3, mm).
Eigen::MatrixX3d grid_prolongation(const Eigen::MatrixX3d& points, double grid_mm, SparseRows& P);

/// P^T A P into `out` for a prolongation whose every fine node's rows (`fine_block` of them) lie
/// in one coarse node's `coarse_block` columns (plain aggregation's), summed in dense blocks on
/// `threads` threads, the `padding` unknowns' rows and columns left empty; false (out untouched)
/// for any other P (galerkin.cpp).
bool galerkin_by_blocks(const SparseRows& A, const SparseRows& P, int fine_block, int coarse_block,
                        const std::vector<int32_t>& padding, int threads, SparseRows& out);

/// The hierarchy again for a new matrix on the same unknowns (a relinearised system): keeps the
/// aggregates and prolongations, computes each coarse operator P^T A P again, the smoothing
/// weights and the coarsest factorisation (its pattern's analysis kept when the pattern is).
/// About half a full build (aggregation and a QR per aggregate are skipped).
void rebuild_operators(SparseRows A, Multigrid& mg);

/// A fixed start for power iterations (every entry nonzero, varying from unknown to unknown):
/// the same estimate every run.
inline void power_iteration_start(Eigen::VectorXd& x) {
  for (Eigen::Index k = 0; k < x.size(); ++k)
    x[k] = 1.0 + 0.5 * std::sin(1.7 * static_cast<double>(k));
}

/// rho(D^-1 A), D^-1 = `inv_diag`, by 15 power-iteration products from power_iteration_start()
/// (the same estimate every run): a damped-Jacobi smoother's weight is 4 / (3 rho).
double jacobi_spectral_radius(const SparseRows& A, const Eigen::VectorXd& inv_diag);

/// Conjugate gradients on A x = b from zero, preconditioned by `precondition(r, z)` (z = B r),
/// until |r| <= tol |b| or `cap` iterations; returns the iterations taken. For measuring a
/// preconditioner (`auto`'s Jacobi trial, bench/multigrid_harness), not for the steps.
template <class Precondition>
int32_t pcg_iterations(const SparseRows& A, const Eigen::VectorXd& b, double tol, int32_t cap,
                       Precondition&& precondition) {
  Eigen::VectorXd x = Eigen::VectorXd::Zero(b.size()), r = b, z(b.size()), p, q;
  precondition(r, z);
  p = z;
  double rz = r.dot(z);
  const double stop2 = tol * tol * b.squaredNorm();
  int32_t it = 0;
  for (; it < cap && r.squaredNorm() > stop2; ++it) {
    q.noalias() = A * p;
    const double alpha = rz / p.dot(q);
    x += alpha * p;
    r -= alpha * q;
    precondition(r, z);
    const double rz_new = r.dot(z);
    p = z + (rz_new / rz) * p;
    rz = rz_new;
  }
  return it;
}

/// One V-cycle from level `from` on levels[from].b into levels[from].x (allocates nothing).
void v_cycle(Multigrid& mg, size_t from);

/// z = B r with the finest level's operator, diagonal and smoothing weight `w` the caller's (the
/// implicit step's exact linearisation: `product(z, y)` sets y = A z), the coarser levels the
/// hierarchy's. B is positive definite while w rho(D^-1 A) < 2 on the finest level. `work` is
/// scratch of r's size. `mask` (1 or 0 per unknown) keeps the correction off unknowns held since
/// the hierarchy was built (their inv_diag is 0): B stays symmetric on the others.
template <class Product>
void v_cycle_with(Multigrid& mg, const Eigen::VectorXd& r, const Eigen::VectorXd& inv_diag,
                  double w, const Eigen::VectorXd& mask, Product&& product, Eigen::VectorXd& z,
                  Eigen::VectorXd& work) {
  MultigridLevel& fine = mg.levels[0];
  z = w * inv_diag.cwiseProduct(r);
  if (mg.levels.size() > 1) {
    product(z, work);
    work = (r - work).cwiseProduct(mask);
    multiply(fine.R_blocks, work, mg.levels[1].b, mg.threads);
    v_cycle(mg, 1);
    multiply(fine.P_blocks, mg.levels[1].x, z, mg.threads, BlockProduct::kAdd);
    z = z.cwiseProduct(mask);
  }
  product(z, work);
  z += w * inv_diag.cwiseProduct(r - work);
}

}  // namespace lamina::sim::detail
