#pragma once
// The sphere model (sphere_model.h) simulated with its far side (y > centre + 12 mm) fixed,
// stiffer than the paper's K = 3 N/m (20 N/m, 8 kg/s damping) so that it settles in a few
// thousand steps; and its skin node nearest to the -y pole, where a +y push acts.

#include <vector>

#include "lamina/sim/simulation.h"
#include "support/sphere_model.h"

namespace lamina::test {

inline sim::Simulation held_sphere(const sim::SolverOptions& options = {}) {
  Eigen::Vector3d c;
  const Model& m = sphere_model(&c);
  sim::Material material;
  material.stiffness_n_per_m = 20.0;
  material.damping_kg_per_s = 8.0;
  sim::Simulation s = sim::make_simulation(m, material, options);
  std::vector<int32_t> fixed;
  for (int32_t i = 0; i < m.node_count(); ++i)
    if (m.X(i, 1) > c.y() + 12.0) fixed.push_back(i);
  sim::fix_nodes(s, fixed);
  return s;
}

/// Physical soft tissue (E = 6 kPa, nu = 0.45, 1.06 g/cm^3 lumped, alpha = 20/s) under implicit
/// Euler at 1 ms: a haptic loop's step.
inline sim::Simulation soft_tissue(const Model& m) {
  const sim::Material material{.stiffness_n_per_m = 0.0,
                               .damping_kg_per_s = 0.0,
                               .mass_damping_per_s = 20.0,
                               .node_mass_kg = 0.0,
                               .young_modulus_kpa = 6.0,
                               .poisson_ratio = 0.45};
  return sim::make_simulation(m, material,
                              {.integrator = sim::Integrator::kImplicitEuler, .dt_s = 0.001});
}

/// The same sphere as soft tissue.
inline sim::Simulation tissue_sphere() {
  Eigen::Vector3d c;
  const Model& m = sphere_model(&c);
  sim::Simulation s = soft_tissue(m);
  std::vector<int32_t> fixed;
  for (int32_t i = 0; i < m.node_count(); ++i)
    if (m.X(i, 1) > c.y() + 12.0) fixed.push_back(i);
  sim::fix_nodes(s, fixed);
  return s;
}

inline int32_t front_node(const Model& m) {
  int32_t best = 0;
  for (int32_t i = 0; i < m.layers[0].node_count; ++i)
    if (m.X(i, 1) < m.X(best, 1)) best = i;
  return best;
}

}  // namespace lamina::test
