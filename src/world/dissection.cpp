// Dissection (dissection.h): the surface a blade's edge sweeps, and the ties it divides.
#include "lamina/world/dissection.h"

#include <algorithm>
#include <cmath>

#include "lamina/core/error.h"
#include "lamina/model/cut_tetrahedra.h"
#include "lamina/world/world.h"

namespace lamina::world {
namespace {

// The blade's upper end at `time_s`: along its path at constant speed.
Eigen::Vector3d on_path(const interact::Scalpel& b, double time_s) {
  double total = 0.0;
  for (size_t k = 1; k < b.path.size(); ++k) total += (b.path[k] - b.path[k - 1]).norm();
  const double f = std::clamp((time_s - b.start_s) / (b.end_s - b.start_s), 0.0, 1.0);
  double left = f * total;
  for (size_t k = 1; k < b.path.size(); ++k) {
    const double len = (b.path[k] - b.path[k - 1]).norm();
    if (left <= len && len > 0.0) return b.path[k - 1] + (left / len) * (b.path[k] - b.path[k - 1]);
    left -= len;
  }
  return b.path.back();
}

}  // namespace

BladeSweep blade_sweep(const interact::Scalpel& blade, double from_s, double to_s) {
  const Eigen::Vector3d down = blade.depth_mm * blade.depth_direction.normalized();
  BladeSweep s;
  s.a0 = on_path(blade, from_s);
  s.b0 = s.a0 + down;
  s.a1 = on_path(blade, to_s);
  s.b1 = s.a1 + down;
  return s;
}

int32_t advance_dissections(const std::vector<Dissection>& dissections, World& world, double from_s,
                            double to_s) {
  int32_t divided = 0;
  for (const Dissection& d : dissections)
    if (to_s >= d.blade.start_s && from_s <= d.blade.end_s)
      divided += divide_ties(world, blade_sweep(d.blade, from_s, to_s), d.reach_mm);
  return divided;
}

void check_stroke(const std::string& what, const std::vector<Eigen::Vector3d>& path,
                  const Eigen::Vector3d& direction, double depth_mm, double reach_mm) {
  if (const auto p = model::blade_problem(path, direction, depth_mm))
    throw invalid_input(what + ": " + p->first, p->second);
  if (!(reach_mm > 0.0 && std::isfinite(reach_mm)))
    throw invalid_input(what + ": reach_mm", "must be > 0 mm");
}

int32_t dissect_along(World& world, const std::vector<Eigen::Vector3d>& path,
                      const Eigen::Vector3d& direction, double depth_mm, double reach_mm) {
  const Eigen::Vector3d down = depth_mm * direction.normalized();
  int32_t divided = 0;
  for (size_t k = 1; k < path.size(); ++k)
    divided +=
        divide_ties(world, {path[k - 1], path[k - 1] + down, path[k], path[k] + down}, reach_mm);
  return divided;
}

}  // namespace lamina::world
