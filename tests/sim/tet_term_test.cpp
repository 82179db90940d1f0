// The tetrahedra's elasticity (src/sim/tet_term.cpp): forces are minus the energy's gradient and
// sum to zero, a homogeneous small strain stores exactly the continuum's energy, the implicit
// product is the forces' derivative, an inverted tetrahedron is pushed back, and a step gives the
// same result on one thread and on two.
#include <gtest/gtest.h>
#include <omp.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <random>

#include "lamina/core/error.h"
#include "lamina/geometry/make_phantom.h"
#include "lamina/model/build_model.h"
#include "lamina/sim/simulation.h"
#include "sim/solver.h"  // white-box: the implicit product
#include "support/random_rows.h"
#include "support/tet_checks.h"
#include "support/tet_phantom.h"

namespace {

using namespace lamina;

TEST(TetTerm, ForcesSumToZeroVanishAtRestAndAreMinusTheEnergyGradient) {
  const Model& m = test::tet_phantom();
  ASSERT_TRUE(m.has_tets());
  for (auto elasticity : {model::TetElasticity::kCoupled, model::TetElasticity::kSprings}) {
    sim::Material mat = test::kTetLiver;
    mat.tet_elasticity = elasticity;
    sim::Simulation s = sim::make_simulation(m, mat);
    Eigen::MatrixX3d f = Eigen::MatrixX3d::Zero(m.node_count(), 3);
    sim::internal_forces(s, m.X, f);
    EXPECT_LT(f.cwiseAbs().maxCoeff(), 1e-9) << "rest is an equilibrium";
    const Eigen::MatrixX3d x = test::jiggle(m.X, 2.0, 3);
    f.setZero();
    sim::internal_forces(s, x, f);
    const double scale = f.cwiseAbs().maxCoeff();
    ASSERT_GT(scale, 0.0);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(f.col(c).sum() / scale, 0.0, 1e-6) << "axis " << c;
    test::expect_forces_are_minus_the_energy_gradient(
        s, x, f, scale, {0, 21, m.surface_node_count() - 1, m.node_count() - 1});
  }
}

// Semi-implicit Euler's limit (explicit_dt_limit) against the truth at rest: the largest
// eigenvalue of M^-1 K, K the forces' derivative by central differences (every term the step
// uses, the volume term between layers included), in a dense eigensolve. The limit must be
// below it. (It is far below, and must be: a limit from this eigenvalue with a 1.5 margin blew
// up the stability suite's 30% indentation, where compressed tetrahedra stiffen.)
TEST(ExplicitLimit, IsBelowTheTrueLimitAtRestOfThePhysicalLiver) {
  const Model& m = test::tet_phantom();
  sim::Material mat = test::kTetLiver;
  mat.mass_damping_per_s = 4.0;  // about what critical damping of the slowest mode gives
  sim::Simulation s = sim::make_simulation(m, mat);
  const Eigen::Index n = m.node_count();
  Eigen::MatrixXd K(3 * n, 3 * n);
  Eigen::MatrixX3d fp(n, 3), fm(n, 3);
  const double h = 1e-4;  // mm
  for (Eigen::Index j = 0; j < 3 * n; ++j) {
    Eigen::MatrixX3d xp = m.X, xm = m.X;
    xp(j / 3, j % 3) += h;
    xm(j / 3, j % 3) -= h;
    fp.setZero();
    fm.setZero();
    sim::internal_forces(s, xp, fp);
    sim::internal_forces(s, xm, fm);
    for (Eigen::Index i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) K(3 * i + c, j) = -(fp(i, c) - fm(i, c)) / (2 * h);  // N/m
  }
  Eigen::VectorXd inv_sqrt_m(3 * n);
  for (Eigen::Index i = 0; i < n; ++i)
    inv_sqrt_m.segment<3>(3 * i).setConstant(1.0 / std::sqrt(s.solver().mass_kg[i]));
  const Eigen::MatrixXd A =
      inv_sqrt_m.asDiagonal() * (0.5 * (K + K.transpose())) * inv_sqrt_m.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(A, Eigen::EigenvaluesOnly);
  const double w2 = eig.eigenvalues().maxCoeff(), c = mat.mass_damping_per_s;
  const double truth = (std::sqrt(c * c + 4.0 * w2) - c) / w2;  // h^2 w^2 + 2 h c = 4
  const double limit = sim::explicit_dt_limit(s);
  EXPECT_GT(limit, 0.0);
  EXPECT_LT(limit, truth) << "unsafe: beyond the true limit at rest";
  std::printf("explicit limit %.1f us, true limit at rest %.1f us\n", limit * 1e6, truth * 1e6);
}

TEST(TetTerm, ASmallHomogeneousStrainStoresTheContinuumsEnergy) {
  // Coupled springs plus the volume term, and stable Neo-Hookean, are linear elasticity at small
  // strain: under x = (I + eps) X the model stores V (mu eps:eps + lambda/2 tr(eps)^2), V the
  // organ's volume.
  const Model& m = test::tet_phantom();
  for (const auto energy : {sim::TetModel::kSprings, sim::TetModel::kNeoHookean}) {
    sim::Material mat = test::kTetLiver;
    mat.tet_model = energy;
    sim::Simulation s = sim::make_simulation(m, mat);
    const double mu = 6.0 / 2.9, lambda = 6.0 * 0.45 / (1.45 * 0.1);
    double volume = 0.0;
    for (double v : s.tet_identification().rest_volume_mm3) volume += v;
    Eigen::Matrix3d shear = Eigen::Matrix3d::Zero();
    shear(0, 1) = shear(1, 0) = 1e-4;
    for (const Eigen::Matrix3d& eps :
         {Eigen::Matrix3d(Eigen::Vector3d(1e-4, 0, 0).asDiagonal()),
          Eigen::Matrix3d(1e-4 * Eigen::Matrix3d::Identity()), shear}) {
      const Eigen::MatrixX3d x = m.X * (Eigen::Matrix3d::Identity() + eps).transpose();
      const double continuum =
          volume * (mu * eps.squaredNorm() + 0.5 * lambda * eps.trace() * eps.trace());
      EXPECT_NEAR(sim::elastic_energy(s, x) * 1e6 / continuum, 1.0, 1e-3)  // J -> mN mm
          << (energy == sim::TetModel::kSprings ? "springs" : "neo_hookean");
    }
  }
}

TEST(TetTerm, ImplicitProductIsTheForcesDerivative) {
  // At rest (no geometric term, V = V0) K p is minus the directional derivative of the forces.
  const Model& m = test::tet_phantom();
  sim::Simulation s =
      sim::make_simulation(m, test::kTetLiver, {.integrator = sim::Integrator::kImplicitEuler});
  sim::step(s);  // linearises at rest (nothing moves: no force)
  const Eigen::MatrixX3d p = test::random_rows(m.node_count(), 1.0, 9);
  const double h = 0.1;
  Eigen::MatrixX3d y = Eigen::MatrixX3d::Zero(m.node_count(), 3);
  sim::implicit_system_product(s, h, p, y);
  // y = (M + h^2 K) p here (no damping given): K p = (y - M p) / h^2.
  Eigen::MatrixX3d kp = y;
  for (int32_t i = 0; i < m.node_count(); ++i)
    kp.row(i) = (y.row(i) - s.mass_kg()[i] * p.row(i)) / (h * h);
  const double e = 1e-6;
  Eigen::MatrixX3d fp = Eigen::MatrixX3d::Zero(m.node_count(), 3), fm = fp;
  sim::internal_forces(s, m.X + e * p, fp);
  sim::internal_forces(s, m.X - e * p, fm);
  const Eigen::MatrixX3d derivative = -(fp - fm) / (2 * e);
  EXPECT_LT((kp - derivative).cwiseAbs().maxCoeff(), 1e-3 * derivative.cwiseAbs().maxCoeff());
}

TEST(TetTerm, AnInvertedTetrahedronIsPushedBack) {
  // Mirror an interior node through the face opposite it: its tetrahedra invert, yet their edge
  // lengths barely change; the signed volume term must bring them back.
  const Model& m = test::tet_phantom();
  sim::Simulation s = sim::make_simulation(
      m,
      {.stiffness_n_per_m = 0.0,
       .damping_kg_per_s = 0.0,
       .mass_damping_per_s = 30.0,
       .node_mass_kg = 0.0,
       .young_modulus_kpa = 6.0,
       .poisson_ratio = 0.45},
      {.integrator = sim::Integrator::kImplicitEuler, .dt_s = 0.005, .cg_tolerance = 1e-4});
  s.x = test::mirror_an_interior_node(m);
  ASSERT_GT(sim::inverted_tets(m, s.x), 0);
  for (int k = 0; k < 400; ++k) sim::step(s);
  EXPECT_EQ(sim::inverted_tets(m, s.x), 0);
  EXPECT_LT((s.x - m.X).rowwise().norm().maxCoeff(), 0.5);
}

TEST(TetTerm, BitForBitForAThreadCountAndToRoundOffAcrossThem) {
  // Every pass writes its own rows and sums per-thread partials in thread order: a run repeats
  // bit for bit with the same thread count; another count adds the partials of a dot product
  // in another grouping, which moves the solution by round-off, amplified at most to the solve's
  // tolerance (1e-6 here) when an iteration count changes.
  static const Model big =
      model::build_model(geometry::make_phantom({.spacing_mm = {3, 3, 3}}), {.skin_vertices = 2000})
          .model;
  auto run = [](int threads) {
    omp_set_num_threads(threads);
    sim::Simulation s = sim::make_simulation(
        big, test::kTetLiver, {.integrator = sim::Integrator::kImplicitEuler, .dt_s = 0.001});
    sim::fix_nodes(s, {0, 1, 2, 3});
    s.f_ext.row(big.node_count() / 2) << 100.0, -50.0, 20.0;
    s.f_ext.row(7) << 0.0, 300.0, 0.0;
    for (int k = 0; k < 20; ++k) sim::step(s);
    return s.x;
  };
  const Eigen::MatrixX3d a = run(1), b = run(2), c = run(2);
  omp_set_num_threads(omp_get_num_procs());
  const double moved = (a - big.X).cwiseAbs().maxCoeff();
  EXPECT_GT(moved, 0.0);
  EXPECT_EQ(b, c);
  EXPECT_LT((a - b).cwiseAbs().maxCoeff(), 1e-5 * moved);
}

TEST(TetTerm, NeedsAModelWithTetrahedraAndNoProjectiveDynamics) {
  const Model links =
      model::build_model(geometry::make_phantom({.spacing_mm = {3, 3, 3}}),
                         {.structure = model::Structure::kLinks, .skin_vertices = 200})
          .model;
  EXPECT_THROW(sim::make_simulation(links, test::kTetLiver), Error);
  EXPECT_THROW(sim::make_simulation(test::tet_phantom(), test::kTetLiver,
                                    {.integrator = sim::Integrator::kProjective}),
               Error);
  sim::Material both = test::kTetLiver;
  both.stiffness_n_per_m = 3.0;
  EXPECT_THROW(sim::make_simulation(test::tet_phantom(), both), Error);
}

}  // namespace
