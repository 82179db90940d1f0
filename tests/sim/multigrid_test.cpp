// The multigrid (src/sim/multigrid.cpp) as implicit Euler's preconditioner and as LOBPCG's for
// the slowest vibration: a symmetric positive definite V-cycle, the same states as Jacobi in
// fewer iterations, held nodes masked without a rebuild, the slowest vibration as a
// factorisation finds it.
#include "sim/multigrid.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>

#include "lamina/core/error.h"
#include "lamina/sim/simulation.h"
#include "sim/force_terms.h"
#include "sim/preconditioner.h"
#include "sim/solver.h"  // white box: the hierarchy and its build count
#include "support/random_rows.h"
#include "support/tet_phantom.h"

namespace {

using namespace lamina;

sim::Simulation poked(sim::Preconditioner preconditioner) {
  return test::poked_tet_phantom({.integrator = sim::Integrator::kImplicitEuler,
                                  .dt_s = 0.01,
                                  .preconditioner = preconditioner});
}

TEST(Multigrid, TheVCycleIsSymmetricPositiveDefinite) {
  const Model& m = test::tet_phantom();
  sim::Simulation s = poked(sim::Preconditioner::kMultigrid);
  sim::prepare_solver(s);
  sim::detail::Multigrid& mg = s.solver().multigrid->mg;
  ASSERT_GE(mg.levels.size(), 2u) << "the test needs a coarse level";
  EXPECT_LT(mg.levels[1].A.rows(), mg.levels[0].A.rows() / 3);
  const Eigen::Index n = mg.levels[0].A.rows();
  ASSERT_EQ(n, 3 * (m.node_count() - 8));
  // The steps smooth the finest level with their own weight (refresh_multigrid): a cycle from
  // it here takes damped Jacobi's, as the slowest vibration's hierarchy does.
  EXPECT_TRUE(mg.caller_smooths);
  EXPECT_THROW(sim::detail::v_cycle(mg, 0), Error);
  mg.caller_smooths = false;
  mg.levels[0].omega =
      4.0 / (3.0 * sim::detail::jacobi_spectral_radius(mg.levels[0].A, mg.levels[0].inv_diag));
  const auto apply = [&](const Eigen::VectorXd& r) {
    mg.levels[0].b = r;
    sim::detail::v_cycle(mg, 0);
    return Eigen::VectorXd(mg.levels[0].x);
  };
  const Eigen::MatrixX3d rows = test::random_rows(static_cast<int32_t>(n), 1.0, 11);
  const Eigen::VectorXd u = rows.col(0), v = rows.col(1);
  const Eigen::VectorXd Bu = apply(u), Bv = apply(v);
  EXPECT_NEAR(u.dot(Bv), v.dot(Bu), 1e-9 * std::abs(u.dot(Bu)));
  EXPECT_GT(u.dot(Bu), 0.0);
  EXPECT_GT(v.dot(Bv), 0.0);
  // A good preconditioner: B A is close to the identity on a smooth vector (a rigid shift).
  Eigen::VectorXd shift = Eigen::VectorXd::Zero(n);
  for (Eigen::Index k = 0; k < n; k += 3) shift[k] = 1.0;
  const Eigen::VectorXd back = apply(mg.levels[0].A * shift);
  EXPECT_LT((back - shift).norm(), 0.5 * shift.norm());
}

// The grid's coarse level (build_multigrid's grid_mm, bench/multigrid_harness --grid): the
// trilinear prolongation carries every rigid motion of the corners to the nodes exactly, the
// cycle stays symmetric positive definite, and it solves the system at rest in a fraction of
// Jacobi's iterations.
TEST(Multigrid, AGridsCoarseLevelCarriesTheRigidMotionsAndPreconditions) {
  sim::Simulation s = poked(sim::Preconditioner::kMultigrid);
  sim::prepare_solver(s);
  const sim::detail::MultigridPreconditioner& p = *s.solver().multigrid;
  const sim::detail::SparseRows A = p.mg.levels[0].A;
  const Model& m = test::tet_phantom();
  Eigen::MatrixX3d points(static_cast<Eigen::Index>(p.nodes.size()), 3);
  for (size_t q = 0; q < p.nodes.size(); ++q)
    points.row(static_cast<Eigen::Index>(q)) = m.X.row(p.nodes[q]);
  const double extent = (points.colwise().maxCoeff() - points.colwise().minCoeff()).maxCoeff();
  sim::detail::Multigrid mg;
  sim::detail::build_multigrid(A, points, mg, /*coarsest_unknowns=*/60, false, extent / 4.0);
  ASSERT_GE(mg.levels.size(), 2u);
  const sim::detail::SparseRows& P = mg.levels[0].P;
  ASSERT_EQ(P.rows(), A.rows());
  EXPECT_LT(P.cols(), A.rows() / 2) << "the grid is coarser than the mesh";
  // Every linear motion of the corners (a rotation, a stretch, a shift) is the nodes' own.
  sim::detail::SparseRows P2;
  const Eigen::MatrixX3d corners = sim::detail::grid_prolongation(points, extent / 4.0, P2);
  ASSERT_EQ(P2.cols(), P.cols());
  EXPECT_EQ((P2 - P).norm(), 0.0);
  const auto motion = [](const Eigen::RowVector3d& x) {
    return Eigen::Vector3d(-x.y() + 0.3 * x.x(), x.x(), 0.5 * x.z() + 2.0);
  };
  Eigen::VectorXd at_corners(P.cols()), at_nodes(A.rows());
  for (Eigen::Index c = 0; c < corners.rows(); ++c)
    at_corners.segment<3>(3 * c) = motion(corners.row(c));
  for (Eigen::Index q = 0; q < points.rows(); ++q)
    at_nodes.segment<3>(3 * q) = motion(points.row(q));
  EXPECT_LT((P * at_corners - at_nodes).cwiseAbs().maxCoeff(), 1e-9 * extent);
  // Symmetric positive definite, and a preconditioner worth its cycle.
  const auto apply = [&](const Eigen::VectorXd& r) {
    mg.levels[0].b = r;
    sim::detail::v_cycle(mg, 0);
    return Eigen::VectorXd(mg.levels[0].x);
  };
  const Eigen::MatrixX3d rows = test::random_rows(static_cast<int32_t>(A.rows()), 1.0, 5);
  const Eigen::VectorXd u = rows.col(0), v = rows.col(1);
  const Eigen::VectorXd Bu = apply(u), Bv = apply(v);
  EXPECT_NEAR(u.dot(Bv), v.dot(Bu), 1e-6 * std::abs(u.dot(Bu)));
  EXPECT_GT(u.dot(Bu), 0.0);
  const Eigen::VectorXd b = A * Eigen::VectorXd::Ones(A.rows());
  const int32_t grid = sim::detail::pcg_iterations(
      A, b, 1e-8, 2000, [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { z = apply(r); });
  const Eigen::VectorXd inv_diag = A.diagonal().cwiseInverse();
  const int32_t jacobi = sim::detail::pcg_iterations(
      A, b, 1e-8, 2000,
      [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { z = inv_diag.cwiseProduct(r); });
  EXPECT_LT(2 * grid, jacobi) << grid << " against Jacobi's " << jacobi;
}

// The coarse operators summed block by block (galerkin.cpp) are Eigen's two sparse products'
// P^T (A P), at every level of a hierarchy (3 fine unknowns a node, then 6), with the padded
// unknowns' rows and columns left empty; a prolongation that spreads a node over two coarse
// nodes (the grid's, smoothed aggregation's) is left to Eigen.
TEST(Multigrid, TheCoarseOperatorsByBlocksAreTheSparseProducts) {
  sim::Simulation s = poked(sim::Preconditioner::kMultigrid);
  sim::prepare_solver(s);
  const sim::detail::Multigrid& mg = s.solver().multigrid->mg;
  ASSERT_GE(mg.levels.size(), 2u);
  for (size_t l = 0; l + 1 < mg.levels.size(); ++l) {
    const sim::detail::MultigridLevel& level = mg.levels[l];
    const std::vector<int32_t>& padding = mg.levels[l + 1].padding;
    const sim::detail::SparseRows AP = level.A * level.P;
    const sim::detail::SparseRows eigen = level.R * AP;
    sim::detail::SparseRows blocks;
    ASSERT_TRUE(
        sim::detail::galerkin_by_blocks(level.A, level.P, level.block, 6, padding, 2, blocks));
    ASSERT_EQ(blocks.rows(), eigen.rows());
    EXPECT_LT((Eigen::MatrixXd(blocks) - Eigen::MatrixXd(eigen)).norm(),
              1e-12 * Eigen::MatrixXd(eigen).norm())
        << "level " << l;
    for (int32_t k : padding) {
      EXPECT_EQ(blocks.row(k).nonZeros(), 0) << "padded row " << k;
      EXPECT_EQ(sim::detail::SparseRows(blocks.transpose()).row(k).nonZeros(), 0);
    }
    EXPECT_LE(blocks.nonZeros(), eigen.nonZeros() + 36 * eigen.rows() / 6);
  }
  // A node spread over two coarse nodes: not plain aggregation's.
  const sim::detail::MultigridLevel& fine = mg.levels[0];
  sim::detail::SparseRows spread = fine.P;
  spread.coeffRef(0, (fine.P.cols() - 1)) += 0.5;
  sim::detail::SparseRows unused;
  EXPECT_FALSE(sim::detail::galerkin_by_blocks(fine.A, spread, 3, 6, {}, 1, unused));
}

TEST(Multigrid, ReachesJacobisStatesInFewerIterations) {
  auto run = [](sim::Preconditioner pre, int32_t& iterations) -> Eigen::MatrixX3d {
    sim::Simulation s = poked(pre);
    EXPECT_EQ(sim::uses_multigrid(s), pre == sim::Preconditioner::kMultigrid);
    iterations = test::step_counting_iterations(s, 150);
    return Eigen::MatrixX3d(s.x);
  };
  int32_t jacobi_iterations = 0, multigrid_iterations = 0;
  const Eigen::MatrixX3d jacobi = run(sim::Preconditioner::kJacobi, jacobi_iterations);
  const Eigen::MatrixX3d multigrid = run(sim::Preconditioner::kMultigrid, multigrid_iterations);
  const Model& m = test::tet_phantom();
  const double motion = (jacobi - m.X).rowwise().norm().maxCoeff();
  ASSERT_GT(motion, 1.0);
  // Both solve each step to the same tolerance (1e-6 of the right side).
  EXPECT_LT((multigrid - jacobi).rowwise().norm().maxCoeff(), 1e-4 * motion);
  EXPECT_GT(jacobi_iterations, 150);
  EXPECT_LT(2 * multigrid_iterations, jacobi_iterations);
}

TEST(Multigrid, NodesHeldAfterTheBuildAreMaskedWithoutARebuild) {
  const Model& m = test::tet_phantom();
  auto run = [&](sim::Preconditioner pre, int64_t* builds) -> Eigen::MatrixX3d {
    sim::Simulation s = poked(pre);
    for (int k = 0; k < 20; ++k) sim::step(s);
    // An indenter takes three nodes and moves them on every step.
    const std::vector<int32_t> held = {m.node_count() / 2, m.node_count() / 2 + 1, 40};
    for (int k = 0; k < 40; ++k) {
      Eigen::MatrixX3d at(3, 3);
      for (int r = 0; r < 3; ++r) at.row(r) = m.X.row(held[r]) + Eigen::RowVector3d(0, 0.05 * k, 0);
      sim::hold_nodes(s, held, at);
      const sim::StepStats st = sim::step(s);
      EXPECT_FALSE(st.recovered);
      for (int r = 0; r < 3; ++r) EXPECT_EQ(s.x.row(held[r]), at.row(r));
    }
    if (builds) *builds = s.solver().multigrid->builds;
    return Eigen::MatrixX3d(s.x);
  };
  int64_t builds = 0;
  const Eigen::MatrixX3d multigrid = run(sim::Preconditioner::kMultigrid, &builds);
  const Eigen::MatrixX3d jacobi = run(sim::Preconditioner::kJacobi, nullptr);
  EXPECT_EQ(builds, 1);
  const double motion = (jacobi - m.X).rowwise().norm().maxCoeff();
  ASSERT_GT(motion, 1.0);
  EXPECT_LT((multigrid - jacobi).rowwise().norm().maxCoeff(), 1e-4 * motion);
}

TEST(Multigrid, FollowsALargeDeformationAndStaysPositiveDefinite) {
  // A push five times the other tests' folds the phantom's tetrahedra far from rest: rho(D^-1 A)
  // of the step's system leaves the margin of a smoother weighted at rest, and the coarse levels'
  // slow modes are no longer the rest state's.
  auto run = [](sim::Preconditioner pre, bool& all_solved) {
    // Jacobi needs more than the default cap of iterations here.
    sim::Simulation s = test::poked_tet_phantom({.integrator = sim::Integrator::kImplicitEuler,
                                                 .dt_s = 0.01,
                                                 .cg_max_iterations = 2000,
                                                 .preconditioner = pre});
    s.f_ext *= 5.0;
    all_solved = true;
    for (int k = 0; k < 60; ++k) {
      const sim::StepStats st = sim::step(s);
      EXPECT_FALSE(st.recovered);
      all_solved = all_solved && st.solver_converged;
    }
    return s;
  };
  bool mg_solved = false, jacobi_solved = false;
  sim::Simulation s = run(sim::Preconditioner::kMultigrid, mg_solved);
  const sim::Simulation j = run(sim::Preconditioner::kJacobi, jacobi_solved);
  EXPECT_TRUE(mg_solved);
  EXPECT_TRUE(jacobi_solved);
  sim::detail::MultigridPreconditioner& p = *s.solver().multigrid;
  EXPECT_EQ(p.fallbacks, 0) << "no step found the V-cycle indefinite";
  EXPECT_GE(p.relinearised, 1) << "the hierarchy followed the deformation";
  const Model& m = test::tet_phantom();
  const double motion = (j.x - m.X).rowwise().norm().maxCoeff();
  ASSERT_GT(motion, 5.0);
  EXPECT_LT((s.x - j.x).rowwise().norm().maxCoeff(), 1e-3 * motion);
  // The last step's V-cycle, as CG applied it: symmetric and positive on random residuals.
  sim::detail::Solver& solver = s.solver();
  const auto apply = [&](const Eigen::MatrixX3d& r) {
    solver.r = r;
    solver.z.setZero(r.rows(), 3);
    const double rz = sim::detail::apply_multigrid(solver, 0.01, 1);
    return std::make_pair(Eigen::MatrixX3d(solver.z), rz);
  };
  for (int seed = 1; seed <= 3; ++seed) {
    Eigen::MatrixX3d u = test::random_rows(m.node_count(), 1.0, 20 + seed),
                     v = test::random_rows(m.node_count(), 1.0, 40 + seed);
    for (int32_t i = 0; i < m.node_count(); ++i)
      if (!solver.movable[i]) u.row(i).setZero(), v.row(i).setZero();
    const auto [Bu, uBu] = apply(u);
    const auto [Bv, vBv] = apply(v);
    EXPECT_GT(uBu, 0.0);
    EXPECT_GT(vBv, 0.0);
    const double uBv = (u.array() * Bv.array()).sum(), vBu = (v.array() * Bu.array()).sum();
    EXPECT_NEAR(uBv, vBu, 1e-9 * std::sqrt(uBu * vBv));
  }
}

TEST(LowestFrequency, ByMultigridLobpcgAsByAFactorisation) {
  // The tetrahedral phantom: the multigrid has a coarse level here (the spring model's test in
  // simulation_test.cpp is small enough to be factored whole).
  const Model& m = test::tet_phantom();
  sim::Simulation s = sim::make_simulation(m, test::kTetLiver);
  sim::fix_nodes(s, {0, 1, 2, 3, 4, 5, 6, 7});
  const double omega = sim::lowest_angular_frequency(s);
  // The reference: a dense eigensolve of M^-1/2 K M^-1/2 over the same rows (about 2,000).
  std::vector<int32_t> row(static_cast<size_t>(m.node_count()), -1);
  int32_t n = 0;
  for (int32_t i = 0; i < m.node_count(); ++i)
    if (!s.fixed()[i]) row[i] = n++;
  const Eigen::SparseMatrix<double> K = sim::detail::rest_stiffness(s.solver(), row, n);
  const Eigen::SparseMatrix<double> Kt = K.transpose();
  EXPECT_LT((K - Kt).norm(), 1e-12 * K.norm()) << "K is symmetric";
  Eigen::VectorXd scale(3 * n);
  for (int32_t i = 0; i < m.node_count(); ++i)
    if (row[i] >= 0) scale.segment<3>(3 * row[i]).setConstant(1.0 / std::sqrt(s.mass_kg()[i]));
  const Eigen::MatrixXd D = scale.asDiagonal() * Eigen::MatrixXd(K) * scale.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(D, Eigen::EigenvaluesOnly);
  // The default stops once what is left of omega, estimated from the iteration's own rate, is
  // under half its tolerance of 1e-4 (measured 1.8e-5 off); asked for 1e-10, it goes on to 1e-6.
  const double exact = std::sqrt(eig.eigenvalues()[0]);
  EXPECT_NEAR(omega, exact, 0.5e-4 * exact);
  EXPECT_NEAR(sim::lowest_angular_frequency(s, 300, 1e-10), exact, 1e-6 * exact);
}

}  // namespace

TEST(Multigrid, RestStiffnessIsTheForcesDerivativeAtRest) {
  // The blocks written into the springs' pattern (block_rows.h) against central differences of
  // the tetrahedra's own forces: K p = -(f(X + e p) - f(X - e p)) / 2e on the movable rows.
  const Model& m = test::tet_phantom();
  sim::Simulation s = sim::make_simulation(m, test::kTetLiver);
  sim::fix_nodes(s, {0, 1, 2, 3, 4, 5, 6, 7});
  std::vector<int32_t> row(static_cast<size_t>(m.node_count()), -1);
  int32_t n = 0;
  for (int32_t i = 0; i < m.node_count(); ++i)
    if (!s.fixed()[i]) row[i] = n++;
  const sim::detail::SparseRows K = sim::detail::rest_stiffness(s.solver(), row, n);
  ASSERT_EQ(K.rows(), 3 * n);
  const Eigen::MatrixX3d p = test::random_rows(m.node_count(), 1.0, 5);
  Eigen::VectorXd pv = Eigen::VectorXd::Zero(3 * n);
  Eigen::MatrixX3d pm = Eigen::MatrixX3d::Zero(m.node_count(), 3);
  for (int32_t i = 0; i < m.node_count(); ++i)
    if (row[i] >= 0) pv.segment<3>(3 * row[i]) = p.row(i).transpose(), pm.row(i) = p.row(i);
  const double e = 1e-5;
  Eigen::MatrixX3d plus = Eigen::MatrixX3d::Zero(m.node_count(), 3), minus = plus;
  sim::detail::CoupledTets::forces(s.solver(), m.X + e * pm, plus);
  sim::detail::CoupledTets::forces(s.solver(), m.X - e * pm, minus);
  const Eigen::VectorXd Kp = K * pv;
  double worst = 0.0, scale = 0.0;
  for (int32_t i = 0; i < m.node_count(); ++i) {
    if (row[i] < 0) continue;
    const Eigen::Vector3d fd = -(plus.row(i) - minus.row(i)).transpose() / (2.0 * e);
    worst = std::max(worst, (Kp.segment<3>(3 * row[i]) - fd).norm());
    scale = std::max(scale, fd.norm());
  }
  ASSERT_GT(scale, 0.0);
  EXPECT_LT(worst, 1e-5 * scale);
}

TEST(Multigrid, AutoTakesJacobiWhereItIsQuickAndTheMultigridWhereItIsNot) {
  // kAuto at rest: at a haptic loop's 1 ms the masses dominate and Jacobi's trial converges in
  // a few iterations; at 50 ms the stiffness does, so much that the trial is not even run (its
  // answer is certain: run here anyway, it reaches the decisive count); at 10 ms the trial
  // decides.
  for (const double dt : {0.001, 0.01, 0.05}) {
    sim::Simulation s = test::poked_tet_phantom({.integrator = sim::Integrator::kImplicitEuler,
                                                 .dt_s = dt,
                                                 .preconditioner = sim::Preconditioner::kAuto});
    sim::prepare_solver(s);
    const sim::detail::MultigridPreconditioner& p = *s.solver().multigrid;
    const bool certain = p.stiffness_ratio >= sim::detail::kAutoCertainRatio;
    EXPECT_EQ(certain, dt > 0.02) << "dt " << dt << ", ratio " << p.stiffness_ratio;
    EXPECT_EQ(p.trial_iterations < 0, certain) << "dt " << dt;
    const bool multigrid = certain || p.trial_iterations >= sim::detail::kAutoTrialIterations;
    if (dt == 0.001) EXPECT_FALSE(multigrid);
    if (certain) {
      const int32_t trial =
          sim::detail::jacobi_trial(sim::detail::to_sparse(p.system), s.options(), 1000);
      EXPECT_GE(trial, 2 * sim::detail::kAutoTrialIterations) << "dt " << dt;
    }
    EXPECT_EQ(sim::uses_multigrid(s), multigrid) << "dt " << dt << ", trial " << p.trial_iterations;
    EXPECT_EQ(p.mg.levels.empty(), !multigrid);
    // Its steps converge with either.
    for (int k = 0; k < 5; ++k) EXPECT_TRUE(sim::step(s).solver_converged) << "dt " << dt;
    EXPECT_EQ(sim::uses_multigrid(s), multigrid);
  }
}
