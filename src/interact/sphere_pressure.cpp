#include "lamina/interact/sphere_pressure.h"

#include <algorithm>
#include <cmath>

#include "lamina/geometry/closest_on_triangle.h"
#include "skin_samples.h"

namespace lamina::interact {

std::optional<std::pair<const char*, const char*>> sphere_problem(const PressingSphere& s) {
  if (!(s.radius_mm > 0.0 && std::isfinite(s.radius_mm))) return {{"radius_mm", "must be > 0 mm"}};
  if (!(s.stiffness_kpa_per_mm > 0.0 && std::isfinite(s.stiffness_kpa_per_mm)))
    return {{"stiffness_kpa_per_mm", "must be > 0 kPa/mm"}};
  if (!s.center_mm.allFinite()) return {{"center_mm", "is not finite"}};
  return std::nullopt;
}

void press_sphere(const Eigen::MatrixX3d& x, const Eigen::MatrixX3d& rest,
                  const Eigen::MatrixX3i& F, const PressingSphere& sphere,
                  std::vector<PressedPiece>& pieces) {
  pieces.clear();
  const double r = sphere.radius_mm, k = sphere.stiffness_kpa_per_mm;
  const Eigen::Vector3d& c = sphere.center_mm;
  const double soft = kSphereRimFraction * r;
  // Cuts from the rest shape, not the current one (spread_on_patch's): a cut count that jumps
  // as a triangle stretches would make the force jump with it, and Newton stall.
  const auto cuts = [&](int32_t f, const Eigen::Vector3d&, double, double) {
    const Eigen::Vector3d a = rest.row(F(f, 0)), b = rest.row(F(f, 1)), e = rest.row(F(f, 2));
    const double longest =
        std::sqrt(std::max({(b - a).squaredNorm(), (e - b).squaredNorm(), (a - e).squaredNorm()}));
    return detail::cuts_for(longest, r / 8.0);
  };
  detail::sample_faces_near(
      F, x, c, r, cuts,
      [&](int32_t f, const Eigen::Vector3d& bary, const Eigen::Vector3d& y, double area) {
        const Eigen::Vector3d away = y - c;
        const double d = away.norm();
        if (!(d < r) || d == 0.0) return;  // outside, or at the centre (no direction)
        const Eigen::Vector3d n = away / d;
        const double depth = r - d;
        // Pressure k (depth - soft / 2), eased in over the first `soft` of depth as
        // k depth^2 / (2 soft): a pressure whose slope has no jump at the rim, where a piece
        // that enters or leaves the sphere would otherwise make Newton cycle.
        const double pressure =
            depth < soft ? k * depth * depth / (2.0 * soft) : k * (depth - 0.5 * soft);
        pieces.push_back({.face = f,
                          .barycentric = bary,
                          .force_mn = (pressure * area) * n,
                          .normal = n,
                          .stiffness_mn_per_mm = k * std::min(depth / soft, 1.0) * area,
                          .distance_mm = d});
      });
}

Eigen::Vector3d pressed_total(const std::vector<PressedPiece>& pieces) {
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  for (const PressedPiece& p : pieces) total += p.force_mn;
  return total;
}

std::optional<Eigen::Vector3d> sphere_first_touch(const Eigen::MatrixX3d& x,
                                                  const Eigen::MatrixX3i& F,
                                                  const Eigen::Vector3d& from_mm,
                                                  const Eigen::Vector3d& direction,
                                                  double radius_mm, double travel_mm) {
  const auto clear = [&](double t) {
    return detail::closest_on_faces(F, x, from_mm + t * direction).distance_mm > radius_mm;
  };
  if (!clear(0.0)) return std::nullopt;
  // March in steps of half the radius to the first centre that touches, then bisect: a sphere
  // cannot pass through a surface between two centres half its radius apart.
  double lo = 0.0, hi = -1.0;
  for (double t = 0.5 * radius_mm; t <= travel_mm + 0.5 * radius_mm; t += 0.5 * radius_mm) {
    if (!clear(std::min(t, travel_mm))) {
      hi = std::min(t, travel_mm);
      break;
    }
    lo = std::min(t, travel_mm);
  }
  if (hi < 0.0) return std::nullopt;
  while (hi - lo > 1e-9 * radius_mm) {
    const double mid = 0.5 * (lo + hi);
    (clear(mid) ? lo : hi) = mid;
  }
  return Eigen::Vector3d(from_mm + lo * direction);
}

}  // namespace lamina::interact
