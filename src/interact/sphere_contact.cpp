#include <cmath>
#include <vector>

#include "lamina/interact/contact.h"
#include "skin_samples.h"

namespace lamina::interact {

ForceRoute sphere_contact(const Model& m, const Eigen::MatrixX3d& x, const ToolTip& tip) {
  ForceRoute route;
  if (m.layers.empty() || !(tip.radius_mm > 0.0)) return route;
  const double r = tip.radius_mm;
  const Eigen::Vector3d& c = tip.center_mm;
  const Eigen::MatrixX3i& F = m.layers[0].F;

  // Each sample inside the sphere: its penetration times its area, pushing away from the centre.
  thread_local std::vector<std::pair<int32_t, Eigen::Vector3d>> parts;
  parts.clear();
  Eigen::Vector3d resultant = Eigen::Vector3d::Zero();
  SkinPoint at;  // the deepest point: the skin's nearest to the centre
  detail::sample_skin_near(
      m, x, c, r,
      [&](int32_t f, const Eigen::Vector3d& bary, double distance) {
        if (distance < at.distance_mm)
          at = {.face = f, .barycentric = bary, .distance_mm = distance};
        // A third of the footprint's radius on a plane at that distance: a few samples cover
        // even a shallow touch of a large triangle.
        return std::sqrt(std::max(r * r - distance * distance, 0.0)) / 3.0;
      },
      [&](int32_t f, const Eigen::Vector3d& bary, const Eigen::Vector3d& y, double area) {
        const Eigen::Vector3d away = y - c;
        const double d = away.norm();
        if (!(d < r) || d == 0.0) return;
        const Eigen::Vector3d w = ((r - d) * area / d) * away;
        resultant += w;
        for (int k = 0; k < 3; ++k)
          if (bary[k] != 0.0) parts.emplace_back(F(f, k), bary[k] * w);
      });
  if (!(at.distance_mm < r)) return route;  // not touching
  for (int k = 0; k < 3; ++k) at.point_mm += at.barycentric[k] * x.row(F(at.face, k)).transpose();

  // The load: stiffness x the deepest penetration, in the direction the samples push.
  const double load = tip.stiffness_n_per_m * (r - at.distance_mm);
  int best = 0;
  at.barycentric.maxCoeff(&best);
  if (resultant.norm() > 1e-12 * r * r * r) {
    detail::merge_parts(parts, route);
    route.forces *= load / resultant.norm();
  } else {
    // No sample inside (a shallow touch between samples) or pushes that cancel (the centre on
    // the skin): the deepest point takes the load, along the skin's inward normal there.
    const Eigen::Vector3d a = x.row(F(at.face, 0)), b = x.row(F(at.face, 1)),
                          e = x.row(F(at.face, 2));
    Eigen::Vector3d dir = at.point_mm - c;
    if (!(dir.norm() > 1e-9 * r)) dir = -(b - a).cross(e - a);
    dir.normalize();
    parts.clear();
    for (int k = 0; k < 3; ++k)
      if (at.barycentric[k] != 0.0)
        parts.emplace_back(F(at.face, k), (load * at.barycentric[k]) * dir);
    detail::merge_parts(parts, route);
  }
  route.contact_node = F(at.face, best);
  return route;
}

}  // namespace lamina::interact
