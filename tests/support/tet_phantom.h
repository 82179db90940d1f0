#pragma once
// A small two-layer phantom filled with tetrahedra (about 700 nodes), built once per test
// program, and the physical liver's material with the springs' own constants off: the tests
// of the tetrahedra's terms, of their assembled stiffness and of the multigrid share both, and
// the poke they step under.

#include <gtest/gtest.h>

#include "lamina/geometry/make_phantom.h"
#include "lamina/model/build_model.h"
#include "lamina/sim/simulation.h"

namespace lamina::test {

inline const Model& tet_phantom() {
  static const Model m = model::build_model(geometry::make_phantom({.spacing_mm = {3, 3, 3}}),
                                            {.display_triangles = 0, .skin_vertices = 400})
                             .model;
  return m;
}

/// Its posterior 15 mm, held (attached to the back wall): what a global-mode model needs.
inline std::vector<int32_t> posterior_nodes(const Model& m) {
  const double back = m.X.col(1).maxCoeff();
  return sim::nodes_near_plane(m, Eigen::Vector3d(0, back, 0), Eigen::Vector3d(0, 1, 0), 15.0);
}

inline const sim::Material kTetLiver{.stiffness_n_per_m = 0.0,
                                     .damping_kg_per_s = 0.0,
                                     .node_mass_kg = 0.0,
                                     .young_modulus_kpa = 6.0,
                                     .poisson_ratio = 0.45};

/// The poke the tests of implicit Euler on this phantom share: the physical material, its first
/// eight nodes fixed, 300 mN along y on one node a third of the way through.
inline sim::Simulation poked_tet_phantom(const sim::SolverOptions& options) {
  const Model& m = tet_phantom();
  sim::Simulation s = sim::make_simulation(m, kTetLiver, options);
  sim::fix_nodes(s, {0, 1, 2, 3, 4, 5, 6, 7});
  s.f_ext.row(m.node_count() / 3) << 0.0, 300.0, 0.0;
  return s;
}

/// Takes `steps` steps, none of which may need a recovery; returns their CG iterations summed.
inline int32_t step_counting_iterations(sim::Simulation& s, int steps) {
  int32_t iterations = 0;
  for (int k = 0; k < steps; ++k) {
    const sim::StepStats st = sim::step(s);
    EXPECT_FALSE(st.recovered);
    iterations += st.cg_iterations;
  }
  return iterations;
}

}  // namespace lamina::test
