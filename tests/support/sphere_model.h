#pragma once
// A two-layer sphere model, radius 20 mm, inner layer 8 mm deep, about 600 skin vertices, filled
// with tetrahedra (or joined by links): built once per test program (an inline function's static is
// shared by every file that uses it).

#include <Eigen/Core>

#include "lamina/model/build_model.h"
#include "support/volumes.h"

namespace lamina::test {

inline const Model& sphere_model(Eigen::Vector3d* centre = nullptr,
                                 model::Structure structure = model::Structure::kTetrahedra) {
  static Eigen::Vector3d c;
  const auto build = [](model::Structure s) {
    LabelVolume v = empty_volume(50, 1.0);
    const auto p = v.frame.to_physical(24.5, 24.5, 24.5);
    c = Eigen::Vector3d(p[0], p[1], p[2]);
    paint_sphere(v, p, 20.0, 1);
    return model::build_model(v, {.structure = s,
                                  .display_triangles = 0,
                                  .skin_vertices = 600,
                                  .layer_depth_mm = 8.0})
        .model;
  };
  if (structure == model::Structure::kTetrahedra) {
    static const Model tets = build(structure);
    if (centre) *centre = c;
    return tets;
  }
  static const Model links = build(structure);
  if (centre) *centre = c;
  return links;
}

/// The same sphere, its layers joined by the paper's nearest-node links.
inline const Model& sphere_links_model() {
  return sphere_model(nullptr, model::Structure::kLinks);
}

}  // namespace lamina::test
