// The multigrid's float block products (src/sim/float_blocks.cpp): the product Eigen's double
// CSR gives, to single precision, for every block shape the hierarchy uses, on one thread and
// on several alike; a restriction stored as the prolongation's exact transpose.
#include "sim/float_blocks.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace {

using namespace lamina;
using sim::detail::BlockProduct;
using sim::detail::FloatBlocks;
using sim::detail::SparseRows;

// A random sparse matrix of `rows` x `cols` whose entries fall anywhere (not block-aligned):
// about `per_row` a row, values in [-1, 1].
SparseRows random_sparse(Eigen::Index rows, Eigen::Index cols, int per_row, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<Eigen::Index> col(0, cols - 1);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  std::vector<Eigen::Triplet<double>> t;
  for (Eigen::Index r = 0; r < rows; ++r)
    for (int k = 0; k < per_row; ++k) t.emplace_back(r, col(rng), value(rng));
  SparseRows m(rows, cols);
  m.setFromTriplets(t.begin(), t.end());
  return m;
}

Eigen::VectorXd random_vector(Eigen::Index n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  Eigen::VectorXd v(n);
  for (double& x : v) x = value(rng);
  return v;
}

TEST(FloatBlocks, EveryShapeAndKindIsEigensProductInSinglePrecision) {
  const int shapes[][2] = {{6, 6}, {3, 6}, {6, 3}, {3, 3}, {2, 4}};
  for (const auto& shape : shapes) {
    const int br = shape[0], bc = shape[1];
    // Large enough to be threaded (kThreadedFloats values).
    const SparseRows m = random_sparse(br * 4000, bc * 3000, 12, 3 + br * bc);
    FloatBlocks f;
    sim::detail::to_float_blocks(m, br, bc, f);
    ASSERT_GE(f.nonzeros(), sim::detail::kThreadedFloats) << "the test needs a threaded product";
    const Eigen::VectorXd x = random_vector(m.cols(), 5), b = random_vector(m.rows(), 6),
                          y0 = random_vector(m.rows(), 7);
    const Eigen::VectorXd mx = m * x;
    const double tol = 1e-6 * mx.norm();
    for (const int threads : {1, 2, 3}) {
      Eigen::VectorXd y(m.rows());
      sim::detail::multiply(f, x, y, threads);
      EXPECT_LT((y - mx).norm(), tol) << br << "x" << bc << " set, " << threads << " threads";
      y = y0;
      sim::detail::multiply(f, x, y, threads, BlockProduct::kAdd);
      EXPECT_LT((y - (y0 + mx)).norm(), tol) << br << "x" << bc << " add";
      sim::detail::multiply(f, x, y, threads, BlockProduct::kResidual, &b);
      EXPECT_LT((y - (b - mx)).norm(), tol) << br << "x" << bc << " residual";
      // Fixed slices, sums in a fixed order: the same bits on any number of threads.
      Eigen::VectorXd one(m.rows()), many(m.rows());
      sim::detail::multiply(f, x, one, 1);
      sim::detail::multiply(f, x, many, threads);
      EXPECT_EQ(one, many);
    }
  }
}

TEST(FloatBlocks, ARestrictionIsItsProlongationsExactTranspose) {
  const SparseRows p = random_sparse(3 * 500, 6 * 80, 4, 9);
  const SparseRows r = p.transpose();
  FloatBlocks pf, rf;
  sim::detail::to_float_blocks(p, 3, 6, pf);
  sim::detail::to_float_blocks(r, 6, 3, rf);
  // u . (P v) == (R u) . v to rounding of the sums only: the stored floats are the same.
  const Eigen::VectorXd u = random_vector(p.rows(), 1), v = random_vector(p.cols(), 2);
  Eigen::VectorXd pv(p.rows()), ru(p.cols());
  sim::detail::multiply(pf, v, pv, 1);
  sim::detail::multiply(rf, u, ru, 1);
  EXPECT_NEAR(u.dot(pv), ru.dot(v), 1e-12 * u.norm() * pv.norm());
  EXPECT_EQ(pf.nonzeros(), rf.nonzeros());
}

TEST(FloatBlocks, AMatrixThatDoesNotDivideIntoItsBlocksIsRefused) {
  const SparseRows m = random_sparse(10, 12, 2, 4);
  FloatBlocks f;
  EXPECT_ANY_THROW(sim::detail::to_float_blocks(m, 3, 6, f));
}

}  // namespace
