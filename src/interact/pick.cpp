#include "lamina/interact/pick.h"

#include <Eigen/Geometry>
#include <limits>

namespace lamina::interact {

SkinHit pick_skin(const Model& m, const Eigen::MatrixX3d& x, const Eigen::Vector3d& origin,
                  const Eigen::Vector3d& direction) {
  SkinHit hit;
  if (m.layers.empty() || !(direction.squaredNorm() > 0.0)) return hit;
  const Eigen::Vector3d d = direction.normalized();
  const Eigen::MatrixX3i& F = m.layers[0].F;
  double best = std::numeric_limits<double>::infinity();
  int32_t best_face = -1;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    // Moller-Trumbore, both sides (a deformed skin may show a triangle's back).
    const Eigen::Vector3d a = x.row(F(f, 0)), b = x.row(F(f, 1)), c = x.row(F(f, 2));
    const Eigen::Vector3d e1 = b - a, e2 = c - a, p = d.cross(e2);
    const double det = e1.dot(p);
    if (std::abs(det) < 1e-12) continue;
    const Eigen::Vector3d s = origin - a;
    const double u = s.dot(p) / det;
    if (u < 0.0 || u > 1.0) continue;
    const Eigen::Vector3d q = s.cross(e1);
    const double v = d.dot(q) / det;
    if (v < 0.0 || u + v > 1.0) continue;
    const double t = e2.dot(q) / det;
    if (t > 0.0 && t < best) best = t, best_face = static_cast<int32_t>(f);
  }
  if (best_face < 0) return hit;
  hit.distance_mm = best;
  hit.point = origin + best * d;
  double nearest = std::numeric_limits<double>::infinity();
  for (int c = 0; c < 3; ++c) {
    const int32_t v = F(best_face, c);
    const double dist = (x.row(v).transpose() - hit.point).squaredNorm();
    if (dist < nearest) nearest = dist, hit.node = v;
  }
  return hit;
}

}  // namespace lamina::interact
