// The scene beside its reading (scene_read.cpp): the paper's scene, the defaults and checks that
// need the model, the fixed nodes, and the run summary with the scene file's spellings.
#include "lamina/io/scene.h"

#include <fmt/format.h>

#include <algorithm>
#include <nlohmann/json.hpp>
#include <string>

#include "io/scene_keys.h"
#include "io/scene_names.h"
#include "lamina/core/log.h"
#include "lamina/interact/contact.h"
#include "lamina/interact/grasp.h"

namespace lamina::io {

using detail::kMilliNewtonsPerNewton;
using detail::Reader;

Scene paper_scene() {
  Scene s;
  s.source = "the paper's scene";
  s.build.structure = model::Structure::kLinks;
  s.elastic = false;
  s.material = sim::Material{};     // K = 3 N/m, gamma = 3 kg/s, unit masses
  s.solver = sim::SolverOptions{};  // semi-implicit Euler, dt = 0.01 s, 1e-3 mm per step
  s.routing.routing = interact::Routing::kPaper;
  return s;
}

void use_elastic_material(Scene& s) {
  s.elastic = true;
  s.material.stiffness_n_per_m = 0.0;
  s.material.node_mass_kg = 0.0;
  if (!s.damping_given) s.material.damping_kg_per_s = 0.0;
}

void resolve_scene_defaults(Scene& s, const Model& m) {
  if (s.routing.ring_spacing_mm == interact::kPaperRingSpacing) {
    s.routing = interact::resolve_ring_spacing(s.routing, m);
    log::info(
        "{}: the paper's rings by distance, {:.2f} mm apart (the edge of this organ's "
        "paper-size skin)",
        s.source, s.routing.ring_spacing_mm);
  }
  if (s.default_tool) {
    // The paper's poke: the most anterior skin node, pushed posteriorly.
    s.tools.push_back({.by_point = false,
                       .vertex = interact::most_anterior_skin_node(m),
                       .force_mn = Eigen::Vector3d(0.0, 0.4 * kMilliNewtonsPerNewton, 0.0),
                       .start_s = 0.0,
                       .end_s = 1.0});
    s.default_tool = false;
  }
  if (s.default_fixed && s.elastic) {
    // Held at the back, where the liver rests against the diaphragm and the posterior wall, by
    // tissue rather than a clamp: a push dents it where it is pushed.
    s.support.push_back({});
    s.default_fixed = false;
  }
  if (s.default_fixed) {
    // The paper's: the posterior 10 mm held in place.
    const double back = m.X.col(1).maxCoeff();
    s.fixed.push_back({.has_plane = true,
                       .plane_point_mm = Eigen::Vector3d(0.0, back, 0.0),
                       .plane_normal = Eigen::Vector3d::UnitY(),
                       .distance_mm = 10.0,
                       .nodes = {}});
    s.default_fixed = false;
  }
}

void check_scene_against_model(const Scene& s, const Model& m) {
  const Reader r(s.source);
  if (const auto p = interact::routing_problem(s.routing, m.rings.locality))
    r.fail("solver." + p->key, p->problem);
  const int32_t skin_nodes = m.layers.at(0).node_count;
  for (size_t k = 0; k < s.tools.size(); ++k) {
    const interact::Tool& t = s.tools[k];
    const std::string path = "tools[" + std::to_string(k) + "]";
    if (!t.by_point && (t.vertex < 0 || t.vertex >= skin_nodes))
      r.fail(path + ".vertex",
             fmt::format("must be a skin node, 0..{}, got {}", skin_nodes - 1, t.vertex));
    if (t.by_point) {
      const double depth = interact::depth_under_skin(m, m.X, t.point_mm);
      if (depth > interact::start_depth_limit_mm(t.radius_mm))
        r.fail(path + ".point",
               fmt::format("[{}, {}, {}] is inside the organ, {:.1f} mm under the skin at rest: a "
                           "tool starts outside the organ or on its skin",
                           t.point_mm.x(), t.point_mm.y(), t.point_mm.z(), depth));
    }
    if (t.grasp) {
      // Something under the jaws at rest, or nothing to hold.
      const Eigen::Vector3d at = t.by_point ? t.point_mm : Eigen::Vector3d(m.X.row(t.vertex));
      if (!interact::anything_under_jaws(m, m.X, {.center_mm = at, .radius_mm = t.radius_mm}))
        r.fail(path + (t.by_point ? ".point" : ".vertex"),
               fmt::format("nothing under the grasper's jaws: no skin node within radius_mm "
                           "({} mm) of [{}, {}, {}] at rest",
                           t.radius_mm, at.x(), at.y(), at.z()));
      continue;
    }
    // The same contact the tool will make: the nearest skin node for the paper's routing, the
    // nearest point of the skin without it.
    if (t.by_point &&
        interact::load_at_point(m, m.X, t.point_mm, Eigen::Vector3d::Zero(), 0.0, s.routing)
                .contact_node < 0)
      r.fail(path + ".point",
             fmt::format("[{}, {}, {}] is farther than solver.contact_threshold_mm ({} mm) from "
                         "the skin at rest",
                         t.point_mm.x(), t.point_mm.y(), t.point_mm.z(),
                         s.routing.contact_threshold_mm));
  }
  for (size_t k = 0; k < s.fixed.size(); ++k)
    for (size_t i = 0; i < s.fixed[k].nodes.size(); ++i)
      if (s.fixed[k].nodes[i] >= m.node_count())
        r.fail(fmt::format("boundary.fixed[{}].nodes[{}]", k, i),
               fmt::format("must be a node of the model, 0..{}, got {}", m.node_count() - 1,
                           s.fixed[k].nodes[i]));
}

std::vector<int32_t> fixed_scene_nodes(const Scene& s, const Model& m) {
  std::vector<int32_t> out;
  for (const FixedRegion& f : s.fixed) {
    if (f.has_plane) {
      const std::vector<int32_t> near =
          sim::nodes_near_plane(m, f.plane_point_mm, f.plane_normal, f.distance_mm);
      out.insert(out.end(), near.begin(), near.end());
    }
    out.insert(out.end(), f.nodes.begin(), f.nodes.end());
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::string integrator_name(sim::Integrator integrator) {
  return std::string(detail::name_of(detail::kIntegrators, integrator));
}

std::string preconditioner_name(sim::Preconditioner preconditioner) {
  return std::string(detail::name_of(detail::kPreconditioners, preconditioner));
}

std::string routing_name(interact::Routing routing) {
  return std::string(detail::name_of(detail::kRoutings, routing));
}

std::string touch_name(interact::Touch touch) {
  return std::string(detail::name_of(detail::kTouches, touch));
}

std::string tet_model_name(sim::TetModel model) {
  return std::string(detail::name_of(detail::kTetModels, model));
}

std::string mode_name(sim::Mode mode) {
  return std::string(detail::name_of(detail::kModes, mode));
}

std::string run_summary_json(const RunSummary& s) {
  nlohmann::ordered_json j;  // keys in this order, the most telling first
  j["scene"] = s.scene;
  j["model"] = s.model;
  j["converged"] = s.converged;
  j["stopped"] = s.stopped;
  j["unstable"] = s.unstable;
  if (s.unstable) j["unstable_reason"] = s.unstable_reason;
  j["steps"] = s.steps;
  j["sim_seconds"] = s.sim_seconds;
  j["wall_seconds"] = s.wall_seconds;
  j["model_seconds"] = s.model_seconds;
  nlohmann::ordered_json stages = nlohmann::ordered_json::object();  // in the order they ran
  for (const auto& [name, sec] : s.setup_stage_seconds) stages[name] = sec;
  j["setup_stage_seconds"] = stages;
  j["max_displacement_mm"] = s.max_displacement_mm;
  j["max_abs_volume_change_pct"] = s.max_abs_volume_change_pct;
  j["final_rest_error_mm"] = s.final_rest_error_mm;
  j["final_volume_change_pct"] = s.final_volume_change_pct;
  j["nan_detected"] = s.recoveries > 0;
  j["recoveries"] = s.recoveries;
  j["integrator"] = integrator_name(s.integrator);
  j["mode"] = mode_name(s.mode);
  j["routing"] = routing_name(s.routing);
  if (!s.preconditioner.empty()) j["preconditioner"] = s.preconditioner;
  j["dt_s"] = s.dt_s;
  j["nodes"] = s.nodes;
  j["springs"] = s.springs;
  j["layers"] = s.layers;
  j["fixed_nodes"] = s.fixed_nodes;
  j["tools"] = s.tools;
  j["steps_per_second"] = s.steps_per_second;
  j["mean_step_us"] = s.mean_step_us;
  j["median_step_us"] = s.median_step_us;
  j["frames"] = s.frames;
  j["max_reaction_n"] = s.max_reaction_n;
  if (s.scalpels > 0) {
    j["scalpels"] = s.scalpels;
    j["cuts"] = s.cuts;
    j["cut_tets"] = s.cut_tets;
    j["cut_new_nodes"] = s.cut_new_nodes;
    j["median_cut_ms"] = s.median_cut_ms;
    j["max_cut_ms"] = s.max_cut_ms;
    nlohmann::ordered_json pieces = nlohmann::ordered_json::array();
    for (const model::CutPiece& p : s.pieces)
      pieces.push_back({{"volume_ml", p.volume_mm3 / 1000.0},
                        {"mass_g", p.mass_kg * 1000.0},
                        {"tets", p.tets},
                        {"nodes", p.nodes}});
    j["pieces"] = pieces;
    nlohmann::ordered_json crossed = nlohmann::ordered_json::array();
    for (const RunSummary::StructureCrossed& c : s.structures_cut)
      crossed.push_back(
          {{"time_s", c.time_s},
           {"name", c.cut.name},
           {"role", std::string(role_name(c.cut.role))},
           {"label", c.cut.label},
           {"position_mm", {c.cut.position_mm.x(), c.cut.position_mm.y(), c.cut.position_mm.z()}},
           {"diameter_mm", c.cut.diameter_mm},
           {"area_mm2", c.cut.area_mm2},
           {"closed", c.cut.closed}});
    j["structures_cut"] = crossed;
  }
  {
    const MaterialReport& m = s.material;
    nlohmann::ordered_json mj;
    mj["elastic"] = m.elastic;
    if (m.elastic) {
      mj["young_modulus_kpa"] = m.elastic_material.young_modulus_kpa;
      mj["poisson_ratio"] = m.elastic_material.poisson_ratio;
      mj["structure"] = std::string(detail::name_of(
          detail::kStructures, m.tets ? model::Structure::kTetrahedra : model::Structure::kLinks));
      if (m.tets) {
        mj["model"] = tet_model_name(m.tet_model);
        mj["tet_elasticity"] =
            std::string(detail::name_of(detail::kTetElasticities, m.tet_elasticity));
        mj["tet_volume_modulus_kpa"] = m.tet_volume_modulus_kpa;
      } else {
        mj["shear_modulus_kpa"] = m.identification.shear_modulus_kpa;
        mj["spring_fit_residual"] = m.identification.fit_residual;
      }
    }
    mj["supported_nodes"] = m.supported_nodes;
    mj["supported_area_mm2"] = m.supported_area_mm2;
    mj["volume_stiffness_kpa"] = m.volume_stiffness_kpa;
    mj["mass_damping_per_s"] = m.mass_damping_per_s;
    if (m.damping_ratio >= 0.0) {
      mj["damping_ratio"] = m.damping_ratio;
      mj["lowest_frequency_hz"] = m.lowest_frequency_hz;
    }
    mj["explicit_dt_limit_s"] = m.explicit_dt_limit_s;
    j["material"] = mj;
  }
  j["realtime"] = s.realtime;
  if (s.realtime) {
    j["rate_hz"] = s.rate_hz;
    j["achieved_rate_hz"] = s.achieved_rate_hz;
    j["real_time_factor"] = s.real_time_factor;
    j["kept_up"] = s.kept_up;
    j["worst_jitter_us"] = s.worst_jitter_us;
    j["p99_jitter_us"] = s.p99_jitter_us;
  }
  return j.dump(2);
}

}  // namespace lamina::io
