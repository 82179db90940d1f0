// What is wrong with a scalpel, named by its scene key (the scene reader and the driver share it).
#include <fmt/format.h>

#include <Eigen/Geometry>
#include <cmath>

#include "lamina/interact/scalpel.h"

namespace lamina::interact {

std::optional<std::pair<std::string, std::string>> scalpel_problem(const Scalpel& s) {
  using P = std::pair<std::string, std::string>;
  if (s.path.size() < 2)
    return P{"path",
             fmt::format("needs at least two points [[x, y, z], ...], got {}", s.path.size())};
  for (size_t k = 0; k < s.path.size(); ++k)
    if (!s.path[k].allFinite()) return P{fmt::format("path[{}]", k), "is not finite"};
  double length = 0.0;
  for (size_t k = 1; k < s.path.size(); ++k) length += (s.path[k] - s.path[k - 1]).norm();
  if (!(length > 0.0)) return P{"path", "has zero length: its points are one"};
  if (!(std::isfinite(s.depth_mm) && s.depth_mm > 0.0)) return P{"depth_mm", "must be > 0 mm"};
  if (!s.depth_direction.allFinite() || !(s.depth_direction.norm() > 0.0))
    return P{"direction", "must be a finite, non-zero vector"};
  double swept = 0.0;
  const Eigen::Vector3d d = s.depth_direction.normalized();
  for (size_t k = 1; k < s.path.size(); ++k) swept += (s.path[k] - s.path[k - 1]).cross(d).norm();
  if (!(swept > 1e-9 * length)) return P{"direction", "runs along the path: it would cut nothing"};
  if (!(std::isfinite(s.start_s) && s.start_s >= 0.0)) return P{"start_s", "must be >= 0 s"};
  if (!(std::isfinite(s.end_s) && s.end_s > s.start_s))
    return P{"end_s", fmt::format("must be after start_s ({})", s.start_s)};
  return std::nullopt;
}

}  // namespace lamina::interact
