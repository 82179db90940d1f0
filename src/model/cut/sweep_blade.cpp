#include <fmt/format.h>

#include <Eigen/Geometry>
#include <cmath>
#include <string>

#include "lamina/core/error.h"
#include "lamina/model/cut_tetrahedra.h"

namespace lamina::model {

std::optional<std::pair<std::string, std::string>> blade_problem(
    const std::vector<Eigen::Vector3d>& path, const Eigen::Vector3d& depth_direction,
    double depth_mm) {
  using P = std::pair<std::string, std::string>;
  if (path.size() < 2)
    return P{"path",
             fmt::format("needs at least two points [[x, y, z], ...], got {}", path.size())};
  for (size_t k = 0; k < path.size(); ++k)
    if (!path[k].allFinite()) return P{fmt::format("path[{}]", k), "is not finite"};
  double length = 0.0;
  for (size_t k = 1; k < path.size(); ++k) length += (path[k] - path[k - 1]).norm();
  if (!(length > 0.0)) return P{"path", "has zero length: its points are one"};
  if (!(std::isfinite(depth_mm) && depth_mm > 0.0))
    return P{"depth_mm", fmt::format("must be > 0 mm, got {}", depth_mm)};
  if (!depth_direction.allFinite() || !(depth_direction.norm() > 0.0))
    return P{"direction", "must be a finite, non-zero vector"};
  // Segments along the depth direction sweep no area: such a blade would cut nothing, which a
  // user would not ask for.
  double swept = 0.0;
  const Eigen::Vector3d d = depth_direction.normalized();
  for (size_t k = 1; k < path.size(); ++k) swept += (path[k] - path[k - 1]).cross(d).norm();
  if (!(swept > 1e-9 * length))
    return P{"direction", "runs along the path: the blade would sweep no surface"};
  return std::nullopt;
}

Blade sweep_blade(const std::vector<Eigen::Vector3d>& path, const Eigen::Vector3d& depth_direction,
                  double depth_mm) {
  if (const auto problem = blade_problem(path, depth_direction, depth_mm))
    throw invalid_input("blade " + problem->first, problem->second);
  const Eigen::Vector3d d = depth_direction.normalized() * depth_mm;

  const auto n = static_cast<Eigen::Index>(path.size());
  Blade b;
  b.V.resize(2 * n, 3);
  for (Eigen::Index k = 0; k < n; ++k) {
    b.V.row(2 * k) = path[static_cast<size_t>(k)].transpose();
    b.V.row(2 * k + 1) = (path[static_cast<size_t>(k)] + d).transpose();
  }
  b.F.resize(2 * (n - 1), 3);
  for (Eigen::Index k = 0; k + 1 < n; ++k) {
    const int a = static_cast<int>(2 * k), c = a + 2;
    b.F.row(2 * k) << a, c, a + 1;
    b.F.row(2 * k + 1) << c, c + 1, a + 1;
  }
  return b;
}

}  // namespace lamina::model
