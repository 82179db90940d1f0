// The generalised winding number: each triangle's signed solid angle at p by Van Oosterom &
// Strackee's formula, tan(Omega / 2) = a . (b x c) / (|a||b||c| + (a.b)|c| + (b.c)|a| + (c.a)|b|)
// with a, b, c its corners relative to p. Written here rather than taken from a library: the
// stack has none (CGAL's Side_of_triangle_mesh would build an AABB tree and a Surface_mesh of a
// skin that moves every step, for what is one query per tool when it comes on). This loop: 119 us
// on the paper-size skin's 2,554 triangles, 1.18 ms on 25,018 (sim_bench BM_DepthUnderSkin).
#include "lamina/geometry/winding_number.h"

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>

namespace lamina::geometry {

double winding_number(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                      const Eigen::Vector3d& p) {
  double sum = 0.0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)).transpose() - p;
    const Eigen::Vector3d b = V.row(F(f, 1)).transpose() - p;
    const Eigen::Vector3d c = V.row(F(f, 2)).transpose() - p;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    const double det = a.dot(b.cross(c));
    const double div = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    sum += 2.0 * std::atan2(det, div);
  }
  return sum / (4.0 * std::numbers::pi);
}

}  // namespace lamina::geometry
