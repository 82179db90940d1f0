// A tool or a grasper from Python's keywords, checked: Simulation.add_tool/add_grasp and
// World.add_tool/add_grasp take the same ones.
#include <fmt/format.h>

#include <cmath>

#include "bindings.h"

namespace lamina::python {

interact::Tool tool_from(const std::string& what, std::optional<Eigen::Vector3d> point_mm,
                         std::optional<int32_t> vertex, const Eigen::Vector3d& force_mn,
                         std::optional<double> start_s, double end_s, double radius_mm,
                         double now_s) {
  if (point_mm.has_value() == vertex.has_value())
    throw invalid_input(what, "give exactly one of point_mm and vertex");
  if (!force_mn.allFinite()) throw invalid_input(what + ": force_mn", "is not finite");
  if (!(radius_mm >= 0.0 && std::isfinite(radius_mm)))
    throw invalid_input(what + ": radius_mm", fmt::format("must be >= 0 mm, got {}", radius_mm));
  interact::Tool t;
  t.by_point = point_mm.has_value();
  if (point_mm) t.point_mm = *point_mm;
  if (vertex) t.vertex = *vertex;
  t.force_mn = force_mn;
  t.start_s = start_s.value_or(now_s);
  t.end_s = end_s;
  t.radius_mm = radius_mm;
  return t;
}

interact::Tool grasp_from(const std::string& what, std::optional<Eigen::Vector3d> point_mm,
                          std::optional<int32_t> vertex, const Eigen::Vector3d& pull_mm,
                          double pull_s, std::optional<double> start_s, double end_s,
                          double radius_mm, double now_s) {
  if (!pull_mm.allFinite()) throw invalid_input(what + ": pull_mm", "is not finite");
  if (!(pull_s > 0.0 && std::isfinite(pull_s)))
    throw invalid_input(what + ": pull_s", fmt::format("must be > 0 s, got {}", pull_s));
  if (!(radius_mm > 0.0 && std::isfinite(radius_mm)))
    throw invalid_input(what + ": radius_mm", fmt::format("must be > 0 mm, got {}", radius_mm));
  interact::Tool t =
      tool_from(what, point_mm, vertex, Eigen::Vector3d::Zero(), start_s, end_s, radius_mm, now_s);
  t.grasp = true;
  t.pull_mm = pull_mm;
  t.pull_s = pull_s;
  return t;
}

}  // namespace lamina::python
