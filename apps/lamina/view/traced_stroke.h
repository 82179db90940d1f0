#pragma once
// A blade drawn with the mouse (the one-organ viewer's scalpel, the world's dissection): the
// points the drag traces on the skin, or beside it at the last hit's depth, and the blade's upper
// end kAboveMm above them along the view direction at the press, so that it enters through the
// skin.
#include <Eigen/Core>
#include <vector>

#include "lamina/render/camera.h"

namespace lamina::cli {

struct TracedStroke {
  static constexpr double kAboveMm = 3.0;  ///< the blade's edge starts this far above the skin
  static constexpr double kStepMm = 0.5;   ///< a point is added once the drag moved this far
  std::vector<Eigen::Vector3d> path;       ///< traced points, mm
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();  ///< the view direction at the press
  double reach_mm = 0.0;  ///< the last hit's distance along the ray (for rays that miss)

  /// The press: `reach_mm` is where the ray hit the skin, or (a miss) the depth to trace at.
  void begin(const render::Ray& ray, double reach) {
    direction = ray.direction.normalized();
    reach_mm = reach;
    path = {ray.origin + reach_mm * ray.direction};
  }
  /// A move: `hit_mm` the skin's distance along the ray, or < 0 when it missed.
  void extend(const render::Ray& ray, double hit_mm) {
    if (hit_mm >= 0.0) reach_mm = hit_mm;
    const Eigen::Vector3d p = ray.origin + reach_mm * ray.direction;
    if ((p - path.back()).norm() >= kStepMm) path.push_back(p);
  }
  /// The blade's upper end: the path lifted kAboveMm against the view direction.
  std::vector<Eigen::Vector3d> blade_top() const {
    std::vector<Eigen::Vector3d> top = path;
    for (Eigen::Vector3d& p : top) p -= kAboveMm * direction;
    return top;
  }
};

}  // namespace lamina::cli
