#include <vector>

#include "lamina/interact/contact.h"
#include "skin_samples.h"

namespace lamina::interact {

ForceRoute spread_on_patch(const Model& m, const Eigen::MatrixX3d& x, const SkinPoint& at,
                           const Eigen::Vector3d& force_mn, double radius_mm) {
  return detail::spread_on_listed(m, x, at, force_mn, radius_mm, nullptr);
}

ForceRoute detail::spread_on_listed(const Model& m, const Eigen::MatrixX3d& x, const SkinPoint& at,
                                    const Eigen::Vector3d& force_mn, double radius_mm,
                                    const std::vector<int32_t>* list) {
  ForceRoute route;
  if (at.face < 0) return route;
  const Eigen::MatrixX3i& F = m.layers[0].F;
  auto corner = [&](int32_t f, int c) -> Eigen::Vector3d { return x.row(F(f, c)).transpose(); };
  auto normal = [&](int32_t f) -> Eigen::Vector3d {
    return (corner(f, 1) - corner(f, 0)).cross(corner(f, 2) - corner(f, 0));
  };
  int best = 0;
  at.barycentric.maxCoeff(&best);
  route.contact_node = F(at.face, best);

  // Weights w = pressure x area per sample; each passes w times its barycentric weights on.
  thread_local std::vector<std::pair<int32_t, Eigen::Vector3d>> parts;
  parts.clear();
  double total = 0.0;
  if (radius_mm > 0.0) {
    const Eigen::Vector3d facing = normal(at.face);
    const double r2 = radius_mm * radius_mm;
    detail::sample_skin_near(
        m, x, at.point_mm, radius_mm,
        [&](int32_t, const Eigen::Vector3d&, double, double longest) {
          return detail::cuts_for(longest, radius_mm / 3.0);
        },
        [&](int32_t f, const Eigen::Vector3d& bary, const Eigen::Vector3d& y, double area) {
          const double q = 1.0 - (y - at.point_mm).squaredNorm() / r2;
          if (q <= 0.0 || normal(f).dot(facing) <= 0.0) return;
          const double w = q * area;
          total += w;
          for (int c = 0; c < 3; ++c)
            if (bary[c] != 0.0) parts.emplace_back(F(f, c), Eigen::Vector3d::Constant(w * bary[c]));
        },
        list);
  }
  if (!(total > 0.0)) {  // a point load: the contact point's own triangle
    parts.clear();
    for (int c = 0; c < 3; ++c)
      if (at.barycentric[c] != 0.0)
        parts.emplace_back(F(at.face, c), Eigen::Vector3d::Constant(at.barycentric[c]));
    total = at.barycentric.sum();
  }
  // The scalar shares went through the merge as constant vectors; scale them to the force.
  detail::merge_parts(parts, route);
  for (Eigen::Index k = 0; k < route.forces.rows(); ++k)
    route.forces.row(k) = (route.forces(k, 0) / total) * force_mn.transpose();
  return route;
}

}  // namespace lamina::interact
