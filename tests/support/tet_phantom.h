#pragma once
// A small two-layer phantom filled with tetrahedra (about 700 nodes), built once per test
// program, and the physical liver's material with the springs' own constants off: the tests
// of the tetrahedra's terms and of their assembled stiffness share both.

#include "lamina/geometry/make_phantom.h"
#include "lamina/model/build_model.h"
#include "lamina/sim/simulation.h"

namespace lamina::test {

inline const Model& tet_phantom() {
  static const Model m =
      model::build_model(geometry::make_phantom({.spacing_mm = {3, 3, 3}}), {.skin_vertices = 400})
          .model;
  return m;
}

inline const sim::Material kTetLiver{.stiffness_n_per_m = 0.0,
                                     .damping_kg_per_s = 0.0,
                                     .node_mass_kg = 0.0,
                                     .young_modulus_kpa = 6.0,
                                     .poisson_ratio = 0.45};

}  // namespace lamina::test
