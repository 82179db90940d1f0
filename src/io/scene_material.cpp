// A scene's material resolved against its model: spring constants from E and nu, the volume
// term, the integrator a physical tissue needs, and damping from a damping ratio.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/io/scene.h"

namespace lamina::io {

MaterialReport resolve_material(Scene& scene, Model& model, const std::vector<int32_t>& fixed) {
  MaterialReport rep;
  sim::Material& mat = scene.material;
  if (scene.elastic) {
    rep.elastic = true;
    rep.elastic_material = scene.elastic_material;
    rep.identification =
        model::identify_springs(model, scene.elastic_material, model.springs.stiffness_n_per_m);
    use_elastic_material(scene);  // the identified constants, the lumped masses
    if (!scene.volume_stiffness_given)
      mat.volume_stiffness_kpa = rep.identification.volume_stiffness_kpa;
    if (!scene.integrator_given) scene.solver.integrator = sim::Integrator::kImplicitEuler;
    if (!scene.damping_given && scene.damping_ratio < 0.0) scene.damping_ratio = 1.0;
    log::info(
        "{}: E = {:.3g} kPa, nu = {:.3g}: shear modulus {:.3g} kPa in the springs (fit residual "
        "{:.2f}), volume term {:.3g} kPa",
        scene.source, scene.elastic_material.young_modulus_kpa,
        scene.elastic_material.poisson_ratio, rep.identification.shear_modulus_kpa,
        rep.identification.fit_residual, mat.volume_stiffness_kpa);
  }
  if (scene.damping_ratio >= 0.0 && fixed.empty() && mat.anchor_stiffness_n_per_m == 0.0)
    throw invalid_input(scene.source,
                        "material.damping_ratio: the model is held nowhere (no fixed nodes, no "
                        "anchor springs), so its slowest motion is a free drift; fix a region "
                        "or give damping_kg_per_s");
  // The material as a simulation resolves it (constants, masses), held as the scene holds it.
  sim::Simulation probe = sim::make_simulation(model, mat, scene.solver);
  sim::fix_nodes(probe, fixed);
  if (scene.damping_ratio >= 0.0) {
    const double omega = sim::lowest_angular_frequency(probe);
    mat.mass_damping_per_s = 2.0 * scene.damping_ratio * omega;
    rep.damping_ratio = scene.damping_ratio;
    rep.lowest_frequency_hz = omega / (2.0 * std::numbers::pi);
    log::info("{}: slowest vibration {:.3g} Hz; damping ratio {:.3g} gives alpha = {:.4g} 1/s",
              scene.source, rep.lowest_frequency_hz, scene.damping_ratio,
              mat.mass_damping_per_s);
  }
  rep.volume_stiffness_kpa = mat.volume_stiffness_kpa;
  rep.mass_damping_per_s = mat.mass_damping_per_s;
  rep.explicit_dt_limit_s = sim::explicit_dt_limit(probe);
  if (scene.solver.integrator == sim::Integrator::kSemiImplicitEuler &&
      scene.solver.dt_s > rep.explicit_dt_limit_s)
    log::warn(
        "{}: dt = {:.3g} s is beyond semi-implicit Euler's stability limit for this material "
        "(about {:.2g} s): each step runs as {} substeps; \"integrator\": \"implicit_euler\" "
        "takes the whole step at once",
        scene.source, scene.solver.dt_s, rep.explicit_dt_limit_s,
        sim::explicit_substeps(scene.solver.dt_s, rep.explicit_dt_limit_s));
  return rep;
}

}  // namespace lamina::io
