// Stable Neo-Hookean tetrahedra (src/sim/neo_hookean_term.cpp): rest is an equilibrium of zero
// energy, forces are minus the energy's gradient, the stiffness at rest is the coupled springs'
// (linear elasticity; the small-strain energy is checked beside theirs, tet_term_test.cpp), the
// implicit product is the forces' derivative wherever its bound does not act and positive
// semi-definite where it does, and an inverted tetrahedron is pushed back.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>

#include "lamina/sim/simulation.h"
#include "sim/force_terms.h"
#include "sim/solver.h"  // white box: the element stiffness
#include "support/random_rows.h"
#include "support/tet_checks.h"
#include "support/tet_phantom.h"

namespace {

using namespace lamina;

sim::Material neo_liver() {
  sim::Material mat = test::kTetLiver;
  mat.tet_model = sim::TetModel::kNeoHookean;
  return mat;
}

TEST(NeoHookean, RestIsAnEquilibriumAndForcesAreMinusTheEnergyGradient) {
  const Model& m = test::tet_phantom();
  sim::Simulation s = sim::make_simulation(m, neo_liver());
  Eigen::MatrixX3d f = Eigen::MatrixX3d::Zero(m.node_count(), 3);
  sim::internal_forces(s, m.X, f);
  EXPECT_LT(f.cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_NEAR(sim::elastic_energy(s, m.X), 0.0, 1e-15);
  for (const double amplitude : {0.5, 3.0}) {  // mild, and enough to invert some tetrahedra
    const Eigen::MatrixX3d x = test::jiggle(m.X, amplitude, 3);
    f.setZero();
    sim::internal_forces(s, x, f);
    const double scale = f.cwiseAbs().maxCoeff();
    ASSERT_GT(scale, 0.0);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(f.col(c).sum() / scale, 0.0, 1e-9) << "axis " << c;
    test::expect_forces_are_minus_the_energy_gradient(
        s, x, f, scale, {0, 21, m.surface_node_count() - 1, m.node_count() - 1});
  }
  // A rigid rotation costs nothing.
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).matrix();
  const Eigen::MatrixX3d rotated = m.X * R.transpose();
  f.setZero();
  sim::internal_forces(s, rotated, f);
  EXPECT_LT(f.cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_NEAR(sim::elastic_energy(s, rotated), 0.0, 1e-12);
}

TEST(NeoHookean, RestStiffnessIsTheCoupledSpringsLinearElasticity) {
  // Both are linear elasticity at rest: the same 3x3 node blocks.
  const Model& m = test::tet_phantom();
  const sim::Simulation neo = sim::make_simulation(m, neo_liver());
  const sim::Simulation coupled = sim::make_simulation(m, test::kTetLiver);
  std::vector<int32_t> row_of(static_cast<size_t>(m.node_count()));
  for (int32_t i = 0; i < m.node_count(); ++i) row_of[static_cast<size_t>(i)] = i;
  const sim::detail::SparseRows a =
      sim::detail::rest_stiffness(neo.solver(), row_of, m.node_count());
  const sim::detail::SparseRows b =
      sim::detail::rest_stiffness(coupled.solver(), row_of, m.node_count());
  const sim::detail::SparseRows difference = a - b;
  const double scale = b.coeffs().cwiseAbs().maxCoeff();
  ASSERT_GT(scale, 0.0);
  // The coupled springs keep Q in single precision (solver.h): equal to about 1e-7 of the largest.
  EXPECT_LT(difference.coeffs().cwiseAbs().maxCoeff(), 1e-5 * scale);
}

// Block k's 16 corner blocks as one 12 x 12 for lane l.
Eigen::Matrix<double, 12, 12> element(const sim::detail::Solver& s, size_t k, int l) {
  double out[16][9][sim::detail::kTetLanes];
  sim::detail::NeoHookeanTets::block_stiffness(s, k, out);
  Eigen::Matrix<double, 12, 12> K;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      for (int v = 0; v < 9; ++v) K(3 * r + v / 3, 3 * c + v % 3) = out[4 * r + c][v][l];
  return K;
}

TEST(NeoHookean, ProductIsTheForcesDerivativeWhereItsBoundDoesNotAct) {
  // Uniformly scaled to J = alpha the pressure vanishes: the bound on J's curvature cannot act
  // and K p is exactly minus the forces' directional derivative.
  const Model& m = test::tet_phantom();
  sim::Simulation sim =
      sim::make_simulation(m, neo_liver(), {.integrator = sim::Integrator::kImplicitEuler});
  sim::detail::Solver& s = sim.solver();
  const double alpha = 1.0 + s.tets.mu_kpa / s.tets.lambda_kpa;
  const Eigen::MatrixX3d x = m.X * std::cbrt(alpha);
  const Eigen::MatrixX3d p = test::random_rows(m.node_count(), 1.0, 9);
  sim::detail::tet_pass(s, x, /*linearise=*/true, 1, &p);
  Eigen::MatrixX3d kp = Eigen::MatrixX3d::Zero(m.node_count(), 3);
  for (int32_t i = 0; i < m.node_count(); ++i)
    sim::detail::gather_tets(s, s.tets.product, i, kp(i, 0), kp(i, 1), kp(i, 2));
  const double e = 1e-6;
  Eigen::MatrixX3d fp = Eigen::MatrixX3d::Zero(m.node_count(), 3), fm = fp;
  sim::internal_forces(sim, x + e * p, fp);
  sim::internal_forces(sim, x - e * p, fm);
  const Eigen::MatrixX3d derivative = -(fp - fm) / (2 * e);
  EXPECT_LT((kp - derivative).cwiseAbs().maxCoeff(), 1e-4 * derivative.cwiseAbs().maxCoeff());
}

TEST(NeoHookean, StiffnessIsSymmetricPositiveSemiDefiniteUnderLargeDeformation) {
  // Jiggled by 4 mm on 3 mm cells and squeezed to 60% along y: tetrahedra stretched, sheared,
  // compressed and inverted, where the exact Hessian is indefinite.
  const Model& m = test::tet_phantom();
  sim::Simulation sim =
      sim::make_simulation(m, neo_liver(), {.integrator = sim::Integrator::kImplicitEuler});
  sim::detail::Solver& s = sim.solver();
  Eigen::MatrixX3d x = test::jiggle(m.X, 4.0, 5);
  x.col(1) *= 0.6;
  ASSERT_GT(sim::inverted_tets(m, x), 0);
  const Eigen::MatrixX3d p = test::random_rows(m.node_count(), 1.0, 11);
  sim::detail::tet_pass(s, x, /*linearise=*/true, 1, &p);
  double worst = 0.0, largest = 0.0, asymmetry = 0.0, product_error = 0.0;
  const auto nt = static_cast<int64_t>(m.tets.size());
  for (int64_t t = 0; t < nt; ++t) {
    const auto k = static_cast<size_t>(t / sim::detail::kTetLanes);
    const int l = static_cast<int>(t % sim::detail::kTetLanes);
    const Eigen::Matrix<double, 12, 12> K = element(s, k, l);
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 12, 12>> eig(0.5 *
                                                                           (K + K.transpose()));
    largest = std::max(largest, eig.eigenvalues().maxCoeff());
    worst = std::min(worst, eig.eigenvalues().minCoeff());
    asymmetry = std::max(asymmetry, (K - K.transpose()).cwiseAbs().maxCoeff());
    // The element product (what CG uses) is this matrix.
    Eigen::Matrix<double, 12, 1> pc, y;
    for (int c = 0; c < 4; ++c)
      for (int d = 0; d < 3; ++d) {
        pc[3 * c + d] = p(m.tets.T(t, c), d);
        y[3 * c + d] = s.tets.product[static_cast<size_t>(12 * t + 3 * c + d)];
      }
    product_error = std::max(product_error, (K * pc - y).cwiseAbs().maxCoeff());
  }
  ASSERT_GT(largest, 0.0);
  EXPECT_GT(worst, -1e-6 * largest) << "an element's stiffness is indefinite";
  EXPECT_LT(asymmetry, 1e-6 * largest);
  EXPECT_LT(product_error, 1e-5 * largest);
}

TEST(NeoHookean, AnInvertedTetrahedronIsPushedBackAndTheOrganReturnsToRest) {
  const Model& m = test::tet_phantom();
  sim::Material mat = neo_liver();
  mat.mass_damping_per_s = 30.0;
  sim::Simulation s = sim::make_simulation(
      m, mat, {.integrator = sim::Integrator::kImplicitEuler, .dt_s = 0.005, .cg_tolerance = 1e-4});
  s.x = test::mirror_an_interior_node(m);
  ASSERT_GT(sim::inverted_tets(m, s.x), 0);
  for (int k = 0; k < 400; ++k) sim::step(s);
  EXPECT_EQ(sim::inverted_tets(m, s.x), 0);
  EXPECT_LT((s.x - m.X).rowwise().norm().maxCoeff(), 0.5);
}

}  // namespace
