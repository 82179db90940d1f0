#pragma once
// A two-layer sphere model, radius 20 mm, inner layer 8 mm deep, about 600 skin vertices: built
// once per test program (an inline function's static is shared by every file that uses it).

#include <Eigen/Core>

#include "lamina/model/build_model.h"
#include "support/volumes.h"

namespace lamina::test {

inline const Model& sphere_model(Eigen::Vector3d* centre = nullptr) {
  static Eigen::Vector3d c;
  static const Model m = [] {
    LabelVolume v = empty_volume(50, 1.0);
    const auto p = v.frame.to_physical(24.5, 24.5, 24.5);
    c = Eigen::Vector3d(p[0], p[1], p[2]);
    paint_sphere(v, p, 20.0, 1);
    return model::build_model(v, {.skin_vertices = 600, .layer_depth_mm = 8.0}).model;
  }();
  if (centre) *centre = c;
  return m;
}

}  // namespace lamina::test
