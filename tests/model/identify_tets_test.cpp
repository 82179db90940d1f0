// Per-tetrahedron constants from E and nu (model::identify_tets).
#include "lamina/model/identify_tets.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include "lamina/core/error.h"
#include "lamina/geometry/make_phantom.h"
#include "lamina/model/build_model.h"
#include "support/sphere_model.h"

namespace {

using namespace lamina;

// Q of tetrahedron t as a full 6x6 matrix.
Eigen::Matrix<double, 6, 6> q_of(const model::TetIdentification& id, Eigen::Index t) {
  Eigen::Matrix<double, 6, 6> q;
  for (int k = 0, at = 0; k < 6; ++k)
    for (int m = k; m < 6; ++m, ++at) q(k, m) = q(m, k) = id.q_n_per_m(t, at);
  return q;
}

TEST(IdentifyTets, CoupledQIsLinearElasticityInEdgeStretches) {
  const Model& m = test::sphere_model();
  const model::TetIdentification id =
      model::identify_tets(m, {.young_modulus_kpa = 6.0, .poisson_ratio = 0.45});
  const double mu = 6.0 / 2.9, lambda = 6.0 * 0.45 / (1.45 * 0.1);
  EXPECT_NEAR(id.shear_modulus_kpa, mu, 1e-12);
  EXPECT_NEAR(id.volume_modulus_kpa, model::kVolumeShare * lambda, 1e-12);
  EXPECT_NEAR(id.guard_modulus_kpa, model::kGuardModulus * (lambda + 2.0 * mu), 1e-12);
  const double lambda_q = (1.0 - model::kVolumeShare) * lambda;  // the springs' share
  // For every tetrahedron: Q positive definite, and under a small homogeneous strain eps the
  // energy 1/2 dl^T Q dl is V (mu eps:eps + lambda_q / 2 tr(eps)^2).
  Eigen::Matrix3d eps;
  eps << 1e-4, 3e-5, -2e-5, 3e-5, -5e-5, 4e-5, -2e-5, 4e-5, 2e-5;
  for (Eigen::Index t = 0; t < m.tets.size(); t += 97) {
    const Eigen::Matrix<double, 6, 6> q = q_of(id, t);
    using Solver = Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>>;
    EXPECT_GT(Solver(q).eigenvalues().minCoeff(), 0.0);
    Eigen::Matrix<double, 6, 1> dl;
    for (int k = 0; k < 6; ++k) {
      const Eigen::Vector3d e = (m.X.row(m.tets.T(t, model::kTetEdge[k][1])) -
                                 m.X.row(m.tets.T(t, model::kTetEdge[k][0])))
                                    .transpose();
      dl[k] = e.dot(eps * e) / e.norm();  // L d.eps.d
    }
    const double volume = id.rest_volume_mm3[static_cast<size_t>(t)];
    const double continuum =
        volume * (mu * eps.squaredNorm() + 0.5 * lambda_q * eps.trace() * eps.trace());
    EXPECT_NEAR(0.5 * dl.dot(q * dl) / continuum, 1.0, 1e-9) << t;
  }
  // Each spring's constant is its tetrahedra's diagonal shares, all positive.
  ASSERT_EQ(id.spring_n_per_m.size(), m.springs.size());
  for (double k : id.spring_n_per_m) EXPECT_GT(k, 0.0);
}

TEST(IdentifyTets, IndependentSpringsHaveNoCouplingAndCarryLambdaMinusMuAside) {
  const Model& m = test::sphere_model();
  const model::TetIdentification id = model::identify_tets(
      m, {.young_modulus_kpa = 6.0, .poisson_ratio = 0.45}, model::TetElasticity::kSprings);
  EXPECT_NEAR(id.volume_modulus_kpa, id.lame_lambda_kpa - id.shear_modulus_kpa, 1e-12);
  for (Eigen::Index t = 0; t < m.tets.size(); t += 53) {
    const Eigen::Matrix<double, 6, 6> q = q_of(id, t);
    EXPECT_EQ((q - Eigen::Matrix<double, 6, 6>(q.diagonal().asDiagonal())).cwiseAbs().maxCoeff(),
              0.0);
    EXPECT_GE(q.diagonal().minCoeff(), 0.0);
  }
}

TEST(IdentifyTets, RefusesAModelWithoutTetrahedraAndBadMaterials) {
  EXPECT_THROW(model::identify_tets(test::sphere_links_model(), {}), Error);
  EXPECT_THROW(model::identify_tets(test::sphere_model(), {.poisson_ratio = 0.5}), Error);
  EXPECT_THROW(model::identify_tets(test::sphere_model(), {.young_modulus_kpa = 0.0}), Error);
}

}  // namespace
