#pragma once
// Reproducible random node values for the solver's tests: vectors to multiply by and shapes
// jiggled off rest.

#include <Eigen/Core>
#include <random>

namespace lamina::test {

/// `rows` rows of three values drawn uniformly from [-amplitude, amplitude], from `seed`.
inline Eigen::MatrixX3d random_rows(Eigen::Index rows, double amplitude, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-amplitude, amplitude);
  Eigen::MatrixX3d p(rows, 3);
  for (Eigen::Index k = 0; k < p.size(); ++k) p.data()[k] = u(rng);
  return p;
}

/// X with every coordinate moved by up to `amplitude` mm.
inline Eigen::MatrixX3d jiggle(const Eigen::MatrixX3d& X, double amplitude, unsigned seed) {
  return X + random_rows(X.rows(), amplitude, seed);
}

}  // namespace lamina::test
