// The finite-element reference's sparse factor (src/validate/sparse_factor.h): CHOLMOD's
// Cholesky on a positive definite tangent, Eigen's LDL^T on an indefinite one, both solving.
#include "sparse_factor.h"

#include <gtest/gtest.h>

#include <vector>

namespace lamina::validate {
namespace {

using Matrix = SparseFactor::Matrix;

// A 3D grid Laplacian plus a small shift (positive definite), n^3 unknowns, full storage as
// fem.cpp keeps K; `sign` -1 negates the second half's block (indefinite, still nonsingular).
Matrix grid_matrix(int n, double sign_of_second_half) {
  const int N = n * n * n;
  std::vector<Eigen::Triplet<double>> t;
  const auto id = [n](int i, int j, int k) { return (k * n + j) * n + i; };
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const int r = id(i, j, k);
        const double s = r >= N / 2 ? sign_of_second_half : 1.0;
        t.emplace_back(r, r, s * 6.1);
        const int nb[3] = {i + 1 < n ? id(i + 1, j, k) : -1, j + 1 < n ? id(i, j + 1, k) : -1,
                           k + 1 < n ? id(i, j, k + 1) : -1};
        for (const int c : nb)
          if (c >= 0 && (c >= N / 2) == (r >= N / 2)) {  // no coupling across the halves
            t.emplace_back(r, c, -s);
            t.emplace_back(c, r, -s);
          }
      }
  Matrix K(N, N);
  K.setFromTriplets(t.begin(), t.end());
  return K;
}

double relative_residual(const Matrix& K, const Eigen::VectorXd& x, const Eigen::VectorXd& b) {
  return (K * x - b).norm() / b.norm();
}

TEST(SparseFactor, APositiveDefiniteTangentIsFactoredByCholeskyAndSolved) {
  const Matrix K = grid_matrix(12, 1.0);
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(K.rows(), -1.0, 2.0);
  SparseFactor f;
  ASSERT_TRUE(f.factorize(K));
  EXPECT_TRUE(f.cholesky());
  Eigen::VectorXd x;
  f.solve(b, x);
  EXPECT_LT(relative_residual(K, x, b), 1e-12);
}

TEST(SparseFactor, AnIndefiniteTangentFallsBackToLdltAndIsSolvedThenCholeskyAgain) {
  const Matrix indefinite = grid_matrix(12, -1.0);
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(indefinite.rows(), -1.0, 2.0);
  SparseFactor f;
  ASSERT_TRUE(f.factorize(indefinite)) << "neither factor took an indefinite, nonsingular K";
  EXPECT_FALSE(f.cholesky());
  Eigen::VectorXd x;
  f.solve(b, x);
  EXPECT_LT(relative_residual(indefinite, x, b), 1e-12);
  // The same pattern positive definite again (Newton past the contact): Cholesky's answer.
  const Matrix definite = grid_matrix(12, 1.0);
  ASSERT_TRUE(f.factorize(definite));
  EXPECT_TRUE(f.cholesky());
  f.solve(b, x);
  EXPECT_LT(relative_residual(definite, x, b), 1e-12);
}

}  // namespace
}  // namespace lamina::validate
