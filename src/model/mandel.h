#pragma once
// Elasticity tensors as 6x6 matrices in Mandel form (strains e11, e22, e33, sqrt2 e23,
// sqrt2 e13, sqrt2 e12), shared by the spring and tetrahedron identifications (internal to
// module model). In this form eps:C:eps is the plain quadratic form and the Frobenius norm is
// the tensor's own, so least-squares fits do not depend on the frame.

#include <Eigen/Core>

namespace lamina::model::detail {

using Mandel = Eigen::Matrix<double, 6, 6>;

/// The isotropic elasticity tensor with Lame constants lambda and mu.
inline Mandel isotropic_tensor(double lambda, double mu) {
  Mandel c = Mandel::Zero();
  c.topLeftCorner<3, 3>().setConstant(lambda);
  for (int a = 0; a < 3; ++a) c(a, a) += 2.0 * mu, c(a + 3, a + 3) = 2.0 * mu;
  return c;
}

}  // namespace lamina::model::detail
