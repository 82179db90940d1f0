// A scene resolved against its model: the material (E and nu into the tetrahedra or into the
// springs, the volume term, the integrator a physical tissue needs, damping from a damping ratio)
// and the one preparation every command shares (prepare_scene).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/io/scene.h"

namespace lamina::io {

MaterialReport resolve_material(Scene& scene, Model& model, const std::vector<int32_t>& fixed,
                                const model::SurfaceSupport& support) {
  MaterialReport rep;
  sim::Material& mat = scene.material;
  if (scene.elastic) {
    rep.elastic = true;
    rep.elastic_material = scene.elastic_material;
    model::check_elastic_material(scene.elastic_material);
    use_elastic_material(scene);  // the model's lumped masses, no raw spring constant
    if (model.has_tets()) {
      // The tetrahedral network carries E and nu itself (its springs, their coupling and each
      // tetrahedron's volume); the volume term between layers is not needed.
      rep.tets = true;
      rep.tet_elasticity = scene.tet_elasticity;
      rep.tet_model = scene.tet_model;
      mat.tet_model = scene.tet_model;
      mat.young_modulus_kpa = scene.elastic_material.young_modulus_kpa;
      mat.poisson_ratio = scene.elastic_material.poisson_ratio;
      mat.tet_elasticity = scene.tet_elasticity;
      const double mu = mat.young_modulus_kpa / (2.0 * (1.0 + mat.poisson_ratio));
      const double lambda = mat.young_modulus_kpa * mat.poisson_ratio /
                            ((1.0 + mat.poisson_ratio) * (1.0 - 2.0 * mat.poisson_ratio));
      rep.tet_volume_modulus_kpa = scene.tet_elasticity == model::TetElasticity::kCoupled
                                       ? model::kVolumeShare * lambda
                                       : std::max(0.0, lambda - mu);
      if (scene.tet_model == sim::TetModel::kNeoHookean) {
        rep.tet_volume_modulus_kpa = lambda + mu;  // lambda' of J's term
        log::info(
            "{}: E = {:.3g} kPa, nu = {:.3g} in {} tetrahedra (stable Neo-Hookean; shear modulus "
            "{:.3g} kPa, volume term lambda + mu = {:.3g} kPa)",
            scene.source, mat.young_modulus_kpa, mat.poisson_ratio, model.tets.size(), mu,
            rep.tet_volume_modulus_kpa);
      } else {
        log::info(
            "{}: E = {:.3g} kPa, nu = {:.3g} in {} tetrahedra ({} springs; shear modulus "
            "{:.3g} kPa, volume term {:.3g} kPa per tetrahedron)",
            scene.source, mat.young_modulus_kpa, mat.poisson_ratio, model.tets.size(),
            scene.tet_elasticity == model::TetElasticity::kCoupled ? "coupled" : "independent", mu,
            rep.tet_volume_modulus_kpa);
      }
    } else {
      if (scene.tet_model == sim::TetModel::kNeoHookean)
        throw invalid_input(scene.source,
                            "material.model neo_hookean needs tetrahedra; the model was built "
                            "with links (model.structure \"links\"): build it with \"tets\"");
      rep.identification =
          model::identify_springs(model, scene.elastic_material, model.springs.stiffness_n_per_m);
      if (!scene.volume_stiffness_given)
        mat.volume_stiffness_kpa = rep.identification.volume_stiffness_kpa;
      log::info(
          "{}: E = {:.3g} kPa, nu = {:.3g}: shear modulus {:.3g} kPa in the springs (fit residual "
          "{:.2f}), volume term {:.3g} kPa",
          scene.source, scene.elastic_material.young_modulus_kpa,
          scene.elastic_material.poisson_ratio, rep.identification.shear_modulus_kpa,
          rep.identification.fit_residual, mat.volume_stiffness_kpa);
    }
    if (!scene.integrator_given) scene.solver.integrator = sim::Integrator::kImplicitEuler;
    if (!scene.damping_given && scene.damping_ratio < 0.0) scene.damping_ratio = 1.0;
  }
  if (scene.damping_ratio >= 0.0 && fixed.empty() && support.nodes.empty() &&
      mat.anchor_stiffness_n_per_m == 0.0)
    throw invalid_input(scene.source,
                        "material.damping_ratio: the model is held nowhere (no fixed nodes, no "
                        "support, no anchor springs), so its slowest motion is a free drift; fix "
                        "or support a region or give damping_kg_per_s");
  // The material as a simulation resolves it (constants, masses), held as the scene holds it.
  sim::Simulation probe = sim::make_simulation(model, mat, scene.solver);
  sim::fix_nodes(probe, fixed);
  sim::support_nodes(probe, support.nodes, support.stiffness_n_per_m);
  if (scene.damping_ratio >= 0.0) {
    const double omega = sim::lowest_angular_frequency(probe);
    mat.mass_damping_per_s = 2.0 * scene.damping_ratio * omega;
    rep.damping_ratio = scene.damping_ratio;
    rep.lowest_frequency_hz = omega / (2.0 * std::numbers::pi);
    log::info("{}: slowest vibration {:.3g} Hz; damping ratio {:.3g} gives alpha = {:.4g} 1/s",
              scene.source, rep.lowest_frequency_hz, scene.damping_ratio, mat.mass_damping_per_s);
  }
  rep.volume_stiffness_kpa = mat.volume_stiffness_kpa;
  rep.mass_damping_per_s = mat.mass_damping_per_s;
  rep.supported_nodes = static_cast<int32_t>(support.nodes.size());
  rep.supported_area_mm2 = support.area_mm2;
  sim::set_parameters(probe, mat, scene.solver);
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

model::SurfaceSupport scene_support(const Scene& scene, const Model& model) {
  // Every supported region adds its springs; a node both fixed and supported is simply fixed.
  model::SurfaceSupport support;
  for (const model::SurfaceSupportOptions& o : scene.support) {
    const model::SurfaceSupport part = model::surface_support(model, o);
    support.nodes.insert(support.nodes.end(), part.nodes.begin(), part.nodes.end());
    support.stiffness_n_per_m.insert(support.stiffness_n_per_m.end(),
                                     part.stiffness_n_per_m.begin(), part.stiffness_n_per_m.end());
    support.area_mm2 += part.area_mm2;
  }
  if (!scene.support.empty() && support.nodes.empty())
    throw invalid_input(scene.source,
                        "boundary.support: no skin faces the given direction within its angle; "
                        "widen max_angle_deg or change the direction");
  return support;
}

SceneSetup prepare_scene(Scene& scene, Model& model) {
  resolve_scene_defaults(scene, model);
  check_scene_against_model(scene, model);
  SceneSetup setup;
  setup.fixed = fixed_scene_nodes(scene, model);
  setup.support = scene_support(scene, model);
  setup.material = resolve_material(scene, model, setup.fixed, setup.support);
  return setup;
}

sim::Simulation make_scene_simulation(const Scene& scene, const Model& model,
                                      const SceneSetup& setup) {
  sim::Simulation s = sim::make_simulation(model, scene.material, scene.solver);
  sim::fix_nodes(s, setup.fixed);
  sim::support_nodes(s, setup.support.nodes, setup.support.stiffness_n_per_m);
  sim::prepare_solver(s);  // the first step as fast as the rest
  return s;
}

}  // namespace lamina::io
