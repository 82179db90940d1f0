#pragma once
// The finite-element reference's sparse factor (fem.cpp): CHOLMOD's supernodal Cholesky, and
// Eigen's simplicial LDL^T where the tangent is not positive definite (a pressing sphere's
// contact curvature can make it indefinite; LDL^T without pivoting still factors most of those).
//
// Why CHOLMOD: the reference is meshed to the model's resolution, and at 43k model nodes that is
// 90k vertices and 520k tetrahedra. SimplicialLDLT had not finished the first solve of such a
// mesh after 31 minutes (docs/validation.md). On the elasticity matrix of an 8,000-vertex cube of
// tetrahedra SimplicialLDLT factored in 11.5 s, CHOLMOD's supernodal Cholesky in 3.84 s on
// Debian's reference BLAS and 0.40 s on OpenBLAS; at 27,000 vertices CHOLMOD took 39.6 s and
// 2.45 s (this 2-core machine; docs/architecture.md).
#include <Eigen/CholmodSupport>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

namespace lamina::validate {

class SparseFactor {
 public:
  using Matrix = Eigen::SparseMatrix<double>;

  SparseFactor() {
    llt_.cholmod().print = 0;  // "not positive definite" is an answer here, not a message
  }

  /// Factors K (its lower triangle; the pattern must stay the one first given). False when
  /// neither factorisation succeeded.
  bool factorize(const Matrix& K) {
    if (!llt_analyzed_) {
      llt_.analyzePattern(K);
      llt_analyzed_ = true;
    }
    llt_.factorize(K);
    use_ldlt_ = llt_.info() != Eigen::Success;
    if (!use_ldlt_) return true;
    if (!ldlt_analyzed_) {
      ldlt_.analyzePattern(K);
      ldlt_analyzed_ = true;
    }
    ldlt_.factorize(K);
    return ldlt_.info() == Eigen::Success;
  }

  /// Whether the last factor is CHOLMOD's Cholesky (K was positive definite).
  bool cholesky() const { return !use_ldlt_; }

  /// x = K^-1 b with the last successful factor.
  template <class Rhs, class Out>
  void solve(const Rhs& b, Out& x) const {
    if (use_ldlt_)
      x = ldlt_.solve(b);
    else
      x = llt_.solve(b);
  }

 private:
  Eigen::CholmodSupernodalLLT<Matrix> llt_;
  Eigen::SimplicialLDLT<Matrix> ldlt_;
  bool llt_analyzed_ = false, ldlt_analyzed_ = false, use_ldlt_ = false;
};

}  // namespace lamina::validate
