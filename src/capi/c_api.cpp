// The C API (include/lamina/c_api.h): thin handles over the C++ library. Every entry point
// catches what the library throws and turns it into a status and the thread's last error, so
// no exception crosses into C.
#include "lamina/c_api.h"

#include <cmath>
#include <exception>
#include <memory>
#include <new>
#include <string>
#include <vector>

#include "c_api_support.h"
#include "lamina/core/error.h"
#include "lamina/io/model_file.h"
#include "lamina/io/scene.h"
#include "lamina/io/scene_model.h"
#include "lamina/model/build_model.h"
#include "lamina/model/embed_surface.h"
#include "lamina/sim/simulation.h"
#include "lamina/world/organ_loop.h"

struct lamina_sim {
  lamina_model model;  // the simulation's own reference (lamina_sim_model hands it out)
  std::unique_ptr<lamina::world::OrganLoop> loop;
  lamina::world::LoopSnapshot snapshot;  // the state after the last call that stepped
  double max_force_n = 3.0, max_force_change_n = 0.05;  // the tool tip's haptic limits
  std::vector<Eigen::MatrixX3d> embedded_x;  // W x per embedded surface, kept between calls
};

// The C roles are the library's, value for value.
static_assert(LAMINA_ROLE_DISPLAY_SKIN == static_cast<int>(lamina::SurfaceRole::kDisplaySkin));
static_assert(LAMINA_ROLE_VESSEL == static_cast<int>(lamina::SurfaceRole::kVessel));
static_assert(LAMINA_ROLE_TUMOUR == static_cast<int>(lamina::SurfaceRole::kTumour));
static_assert(LAMINA_ROLE_STRUCTURE == static_cast<int>(lamina::SurfaceRole::kStructure));
static_assert(LAMINA_ROLE_WOUND == static_cast<int>(lamina::SurfaceRole::kWound));

namespace {

using lamina::Error;
using lamina::ErrorKind;

using lamina::capi::copy_points;
using lamina::capi::guarded;
using lamina::capi::last_error;
using lamina::capi::need;
using lamina::capi::need_capacity;
using lamina::capi::need_finite;
using lamina::capi::need_text;

// Embedded surface k of a model, or an error naming `what` and the range.
const lamina::EmbeddedSurface& need_embedded(const lamina_model* model, int32_t k,
                                             const std::string& what) {
  const lamina::Model& m = *need(model, (what + ": model").c_str()).model;
  if (k < 0 || static_cast<size_t>(k) >= m.embedded.size())
    throw lamina::invalid_input(what + ": k", "is " + std::to_string(k) + "; the model has " +
                                                  std::to_string(m.embedded.size()) +
                                                  " embedded surfaces");
  return m.embedded[static_cast<size_t>(k)];
}

void copy_triangles(const Eigen::MatrixX3i& f, int32_t* indices) {
  for (Eigen::Index t = 0; t < f.rows(); ++t)
    for (int c = 0; c < 3; ++c) indices[3 * t + c] = f(t, c);
}

lamina::sim::Material to_material(const lamina_material& m) {
  lamina::sim::Material out;
  out.stiffness_n_per_m = m.stiffness_n_per_m;
  out.damping_kg_per_s = m.damping_kg_per_s;
  out.node_mass_kg = m.node_mass_kg;
  out.young_modulus_kpa = m.young_modulus_kpa;
  out.poisson_ratio = m.poisson_ratio;
  out.volume_stiffness_kpa = m.volume_stiffness_kpa;
  if (m.tet_model != LAMINA_TETS_SPRINGS && m.tet_model != LAMINA_TETS_NEO_HOOKEAN)
    throw lamina::invalid_input(
        "lamina_material.tet_model",
        "is " + std::to_string(m.tet_model) +
            "; LAMINA_TETS_SPRINGS (0) or LAMINA_TETS_NEO_HOOKEAN (1) expected");
  out.tet_model = m.tet_model == LAMINA_TETS_NEO_HOOKEAN ? lamina::sim::TetModel::kNeoHookean
                                                         : lamina::sim::TetModel::kSprings;
  return out;
}

lamina::sim::SolverOptions to_solver(const lamina_solver& s) {
  if (s.integrator < LAMINA_SEMI_IMPLICIT_EULER || s.integrator > LAMINA_PROJECTIVE)
    throw lamina::invalid_input("lamina_solver.integrator",
                                "is " + std::to_string(s.integrator) + "; 0, 1 or 2 expected");
  lamina::sim::SolverOptions out;
  out.integrator = static_cast<lamina::sim::Integrator>(s.integrator);
  out.dt_s = s.dt_s;
  out.rest_speed_mm_per_s = s.rest_speed_mm_per_s;
  return out;
}

// A simulation stepped on the caller's thread: the realtime loop's forces, tool tip and
// reaction, without its thread or its clock (steps of the solver's own dt).
lamina_sim* wrap(std::shared_ptr<const lamina::Model> model, lamina::sim::Simulation sim,
                 const lamina::interact::RoutingOptions& routing) {
  auto out = std::make_unique<lamina_sim>();
  out->model.model = std::move(model);
  lamina::world::LoopOptions options;
  options.rate_hz = 0.0;
  options.real_time = false;
  out->loop = std::make_unique<lamina::world::OrganLoop>(out->model.model, std::move(sim), routing,
                                                         options);
  out->loop->run_steps(0);  // publishes the state at rest
  out->loop->latest(out->snapshot);
  return out.release();
}

}  // namespace

extern "C" {

const char* lamina_last_error(void) {
  return last_error().c_str();
}

const char* lamina_version(void) {
  return LAMINA_VERSION;
}

lamina_status lamina_model_build(const char* input, lamina_model** out) {
  return guarded([&] {
    need(out, "lamina_model_build: out") = nullptr;
    const std::string what = need_text(input, "lamina_model_build: input");
    const lamina::LabelVolume volume = lamina::io::read_input(what);
    auto model = std::make_shared<lamina::Model>(
        lamina::model::build_model(volume, lamina::model::BuildOptions{}).model);
    *out = new lamina_model{std::move(model)};
  });
}

lamina_status lamina_model_load(const char* path, lamina_model** out) {
  return guarded([&] {
    need(out, "lamina_model_load: out") = nullptr;
    auto model = std::make_shared<lamina::Model>(
        lamina::io::load_model(need_text(path, "lamina_model_load: path")));
    *out = new lamina_model{std::move(model)};
  });
}

lamina_status lamina_model_save(const lamina_model* model, const char* path) {
  return guarded([&] {
    lamina::io::save_model(*need(model, "lamina_model_save: model").model,
                           need_text(path, "lamina_model_save: path"));
  });
}

void lamina_model_free(lamina_model* model) {
  delete model;
}

int32_t lamina_model_node_count(const lamina_model* model) {
  return model ? model->model->node_count() : 0;
}
int32_t lamina_model_layer_count(const lamina_model* model) {
  return model ? model->model->layer_count() : 0;
}
int32_t lamina_model_skin_node_count(const lamina_model* model) {
  return model && !model->model->layers.empty() ? model->model->layers[0].node_count : 0;
}
int32_t lamina_model_skin_triangle_count(const lamina_model* model) {
  return model && !model->model->layers.empty()
             ? static_cast<int32_t>(model->model->layers[0].F.rows())
             : 0;
}

lamina_status lamina_model_skin_triangles(const lamina_model* model, int32_t* indices,
                                          int64_t capacity) {
  return guarded([&] {
    const Eigen::MatrixX3i& f =
        need(model, "lamina_model_skin_triangles: model").model->layers[0].F;
    need(indices, "lamina_model_skin_triangles: indices");
    need_capacity(capacity, 3 * f.rows(), "lamina_model_skin_triangles: indices");
    copy_triangles(f, indices);
  });
}

int32_t lamina_model_embedded_count(const lamina_model* model) {
  return model ? static_cast<int32_t>(model->model->embedded.size()) : 0;
}

lamina_status lamina_model_embedded_info(const lamina_model* model, int32_t k,
                                         lamina_embedded_info* info) {
  return guarded([&] {
    const lamina::EmbeddedSurface& e = need_embedded(model, k, "lamina_model_embedded_info");
    need(info, "lamina_model_embedded_info: info") = {
        .name = e.name.c_str(),
        .label = e.label,
        .vertex_count = static_cast<int32_t>(e.V.rows()),
        .triangle_count = static_cast<int32_t>(e.F.rows()),
        .outside = e.outside,
        .role = static_cast<int32_t>(e.role)};
  });
}

lamina_status lamina_model_embedded_triangles(const lamina_model* model, int32_t k,
                                              int32_t* indices, int64_t capacity) {
  return guarded([&] {
    const Eigen::MatrixX3i& f = need_embedded(model, k, "lamina_model_embedded_triangles").F;
    need(indices, "lamina_model_embedded_triangles: indices");
    need_capacity(capacity, 3 * f.rows(), "lamina_model_embedded_triangles: indices");
    copy_triangles(f, indices);
  });
}

lamina_status lamina_model_embedded_rest_positions(const lamina_model* model, int32_t k,
                                                   double* xyz, int64_t capacity) {
  return guarded([&] {
    const Eigen::MatrixX3d& v = need_embedded(model, k, "lamina_model_embedded_rest_positions").V;
    need(xyz, "lamina_model_embedded_rest_positions: xyz");
    need_capacity(capacity, 3 * v.rows(), "lamina_model_embedded_rest_positions: xyz");
    copy_points(v, xyz);
  });
}

lamina_status lamina_model_rest_positions(const lamina_model* model, double* xyz,
                                          int64_t capacity) {
  return guarded([&] {
    const lamina::Model& m = *need(model, "lamina_model_rest_positions: model").model;
    need(xyz, "lamina_model_rest_positions: xyz");
    need_capacity(capacity, 3 * int64_t{m.node_count()}, "lamina_model_rest_positions: xyz");
    copy_points(m.X, xyz);
  });
}

void lamina_material_defaults(lamina_material* material) {
  if (material == nullptr) return;
  const lamina::sim::Material d;
  *material = {d.stiffness_n_per_m,
               d.damping_kg_per_s,
               d.node_mass_kg,
               d.young_modulus_kpa,
               d.poisson_ratio,
               d.volume_stiffness_kpa,
               d.tet_model == lamina::sim::TetModel::kNeoHookean ? LAMINA_TETS_NEO_HOOKEAN
                                                                 : LAMINA_TETS_SPRINGS};
}

void lamina_solver_defaults(lamina_solver* solver) {
  if (solver == nullptr) return;
  const lamina::sim::SolverOptions d;
  *solver = {static_cast<int32_t>(d.integrator), d.dt_s, d.rest_speed_mm_per_s};
}

lamina_status lamina_sim_create(const lamina_model* model, const lamina_material* material,
                                const lamina_solver* solver, const int32_t* fixed_nodes,
                                int32_t fixed_count, lamina_sim** out) {
  return guarded([&] {
    need(out, "lamina_sim_create: out") = nullptr;
    const auto& shared = need(model, "lamina_sim_create: model").model;
    lamina_material m;
    lamina_material_defaults(&m);
    lamina_solver s;
    lamina_solver_defaults(&s);
    const lamina::sim::Material mat = to_material(material ? *material : m);
    lamina::sim::Simulation sim =
        lamina::sim::make_simulation(*shared, mat, to_solver(solver ? *solver : s));
    if (fixed_count < 0)
      throw lamina::invalid_input("lamina_sim_create: fixed_count", "is negative");
    if (fixed_count > 0) {
      need(fixed_nodes, "lamina_sim_create: fixed_nodes");
      lamina::sim::fix_nodes(sim, std::vector<int32_t>(fixed_nodes, fixed_nodes + fixed_count));
    }
    // A physical tissue (E, no raw spring constant) conserves a tool's force; the paper's
    // constants route it the paper's way (as in scenes and Python).
    const bool elastic = mat.young_modulus_kpa > 0.0 && mat.stiffness_n_per_m == 0.0;
    *out = wrap(shared, std::move(sim),
                {.routing = elastic ? lamina::interact::Routing::kNone
                                    : lamina::interact::Routing::kPaper});
  });
}

lamina_status lamina_sim_create_from_scene(const char* scene, lamina_sim** out) {
  return guarded([&] {
    need(out, "lamina_sim_create_from_scene: out") = nullptr;
    lamina::io::Scene s =
        lamina::io::scene_for(need_text(scene, "lamina_sim_create_from_scene: scene"));
    lamina::io::ReadyScene ready = lamina::io::make_ready_scene(s);
    lamina::io::warn_scalpels_ignored(ready.scene);
    lamina::sim::Simulation sim = lamina::io::make_scene_simulation(ready);
    *out = wrap(std::move(ready.model), std::move(sim), ready.scene.routing);
  });
}

void lamina_sim_free(lamina_sim* sim) {
  delete sim;
}

lamina_status lamina_sim_set_tool_tip(lamina_sim* sim, const double center_mm[3], double radius_mm,
                                      double stiffness_n_per_m) {
  return guarded([&] {
    lamina_sim& s = need(sim, "lamina_sim_set_tool_tip: sim");
    need(center_mm, "lamina_sim_set_tool_tip: center_mm");
    need_finite(center_mm, 3, "lamina_sim_set_tool_tip: center_mm");
    if (!(radius_mm > 0.0) || !std::isfinite(radius_mm))
      throw lamina::invalid_input("lamina_sim_set_tool_tip: radius_mm",
                                  "is " + std::to_string(radius_mm) + "; a positive size expected");
    if (!(stiffness_n_per_m >= 0.0) || !std::isfinite(stiffness_n_per_m))
      throw lamina::invalid_input(
          "lamina_sim_set_tool_tip: stiffness_n_per_m",
          "is " + std::to_string(stiffness_n_per_m) + "; zero or positive expected");
    lamina::interact::ToolTip tip;
    tip.active = true;
    tip.center_mm = Eigen::Vector3d(center_mm[0], center_mm[1], center_mm[2]);
    tip.radius_mm = radius_mm;
    tip.stiffness_n_per_m = stiffness_n_per_m;
    tip.max_force_n = s.max_force_n;
    tip.max_force_change_n = s.max_force_change_n;
    s.loop->set_tool_tip(tip);
  });
}

lamina_status lamina_sim_set_grasper(lamina_sim* sim, const double center_mm[3], double radius_mm) {
  return guarded([&] {
    lamina_sim& s = need(sim, "lamina_sim_set_grasper: sim");
    need(center_mm, "lamina_sim_set_grasper: center_mm");
    need_finite(center_mm, 3, "lamina_sim_set_grasper: center_mm");
    if (!(radius_mm > 0.0) || !std::isfinite(radius_mm))
      throw lamina::invalid_input("lamina_sim_set_grasper: radius_mm",
                                  "is " + std::to_string(radius_mm) + "; a positive size expected");
    s.loop->set_grasper(lamina::interact::Jaws{
        .center_mm = Eigen::Vector3d(center_mm[0], center_mm[1], center_mm[2]),
        .radius_mm = radius_mm});
  });
}

lamina_status lamina_sim_release_grasper(lamina_sim* sim) {
  return guarded(
      [&] { need(sim, "lamina_sim_release_grasper: sim").loop->set_grasper(std::nullopt); });
}

lamina_status lamina_sim_set_haptic_limits(lamina_sim* sim, double max_force_n,
                                           double max_force_change_n) {
  return guarded([&] {
    lamina_sim& s = need(sim, "lamina_sim_set_haptic_limits: sim");
    if (!(max_force_n > 0.0 && std::isfinite(max_force_n)))
      throw lamina::invalid_input("lamina_sim_set_haptic_limits: max_force_n",
                                  "is " + std::to_string(max_force_n) + "; a positive force, N");
    if (!(max_force_change_n > 0.0 && std::isfinite(max_force_change_n)))
      throw lamina::invalid_input(
          "lamina_sim_set_haptic_limits: max_force_change_n",
          "is " + std::to_string(max_force_change_n) + "; a positive force a step, N");
    s.max_force_n = max_force_n;
    s.max_force_change_n = max_force_change_n;
  });
}

lamina_status lamina_sim_clear_tool_tip(lamina_sim* sim) {
  return guarded([&] { need(sim, "lamina_sim_clear_tool_tip: sim").loop->set_tool_tip({}); });
}

lamina_status lamina_sim_set_forces(lamina_sim* sim, const int32_t* skin_nodes,
                                    const double* forces_mn, int32_t count) {
  return guarded([&] {
    lamina_sim& s = need(sim, "lamina_sim_set_forces: sim");
    if (count < 0) throw lamina::invalid_input("lamina_sim_set_forces: count", "is negative");
    if (count > 0) {
      need(skin_nodes, "lamina_sim_set_forces: skin_nodes");
      need(forces_mn, "lamina_sim_set_forces: forces_mn");
      need_finite(forces_mn, 3 * count, "lamina_sim_set_forces: forces_mn");
    }
    const int32_t skin = lamina_model_skin_node_count(&s.model);
    std::vector<lamina::interact::LiveForce> forces(count);
    for (int32_t k = 0; k < count; ++k) {
      if (skin_nodes[k] < 0 || skin_nodes[k] >= skin)
        throw lamina::invalid_input("lamina_sim_set_forces: skin_nodes[" + std::to_string(k) + "]",
                                    "is " + std::to_string(skin_nodes[k]) + "; a skin node (0.." +
                                        std::to_string(skin - 1) + ") expected");
      forces[k].node = skin_nodes[k];
      forces[k].force_mn =
          Eigen::Vector3d(forces_mn[3 * k], forces_mn[3 * k + 1], forces_mn[3 * k + 2]);
    }
    s.loop->set_forces(std::move(forces));
  });
}

lamina_status lamina_sim_step(lamina_sim* sim, int32_t steps, lamina_step_stats* stats) {
  return guarded([&] {
    lamina_sim& s = need(sim, "lamina_sim_step: sim");
    if (steps < 0) throw lamina::invalid_input("lamina_sim_step: steps", "is negative");
    s.loop->run_steps(steps);
    s.loop->latest(s.snapshot);
    if (s.snapshot.stats.unstable != lamina::sim::Instability::kNone)
      throw Error(ErrorKind::kUnstable,
                  "lamina_sim_step: unstable at t = " + std::to_string(s.snapshot.time_s) +
                      " s: " + lamina::sim::describe(s.snapshot.stats.unstable) +
                      "; lower dt, the forces or the stiffness, then lamina_sim_reset");
    if (stats == nullptr) return;
    const lamina::world::LoopSnapshot& p = s.snapshot;
    stats->time_s = p.time_s;
    stats->steps = p.steps;
    stats->max_displacement_mm = p.stats.max_displacement_mm;
    stats->volume_change_pct = p.stats.volume_change_pct;
    for (int c = 0; c < 3; ++c) stats->reaction_mn[c] = p.reaction_mn[c];
    stats->at_rest = lamina::sim::at_rest(p.stats) ? 1 : 0;
    stats->tool_tip_touching = p.tool_tip_touching ? 1 : 0;
    stats->recoveries = p.recoveries;
    stats->grasped_nodes = static_cast<int32_t>(p.grasped_nodes.size());
  });
}

lamina_status lamina_sim_reset(lamina_sim* sim) {
  return guarded([&] {
    lamina_sim& s = need(sim, "lamina_sim_reset: sim");
    s.loop->reset();
    s.loop->run_steps(0);
    s.loop->latest(s.snapshot);
  });
}

lamina_status lamina_sim_cut(lamina_sim* sim, const double* path_xyz, int32_t points,
                             const double direction[3], double depth_mm,
                             lamina_cut_report* report) {
  return guarded([&] {
    lamina_sim& s = need(sim, "lamina_sim_cut: sim");
    need(path_xyz, "lamina_sim_cut: path_xyz");
    need(direction, "lamina_sim_cut: direction");
    if (points < 2 || points > 1'000'000)
      throw lamina::invalid_input("lamina_sim_cut: points",
                                  "must be 2..1000000, got " + std::to_string(points));
    std::vector<Eigen::Vector3d> path(static_cast<size_t>(points));
    for (int32_t k = 0; k < points; ++k)
      path[static_cast<size_t>(k)] =
          Eigen::Vector3d(path_xyz[3 * k], path_xyz[3 * k + 1], path_xyz[3 * k + 2]);
    s.loop->cut(std::move(path), Eigen::Vector3d(direction[0], direction[1], direction[2]),
                depth_mm);
    s.loop->run_steps(0);  // the cut, now, on this thread
    s.loop->latest(s.snapshot);
    if (!s.snapshot.cut_error.empty())
      throw lamina::invalid_input("lamina_sim_cut", s.snapshot.cut_error);
    if (s.snapshot.model) s.model.model = s.snapshot.model;
    s.embedded_x.resize(s.model.model->embedded.size());
    if (report == nullptr) return;
    const lamina::model::CutReport& r = s.snapshot.last_cut;
    report->cut_tets = r.cut_tets;
    report->new_nodes = r.new_nodes;
    report->pieces = static_cast<int32_t>(r.pieces.size());
    report->largest_piece_ml = r.pieces.empty() ? 0.0 : r.pieces[0].volume_mm3 / 1000.0;
    report->structures_cut = static_cast<int32_t>(r.structures_cut.size());
  });
}

int32_t lamina_sim_node_count(const lamina_sim* sim) {
  return sim ? sim->model.model->node_count() : 0;
}

const lamina_model* lamina_sim_model(const lamina_sim* sim) {
  return sim ? &sim->model : nullptr;
}

lamina_status lamina_sim_positions(const lamina_sim* sim, double* xyz, int64_t capacity) {
  return guarded([&] {
    const lamina_sim& s = need(sim, "lamina_sim_positions: sim");
    need(xyz, "lamina_sim_positions: xyz");
    need_capacity(capacity, 3 * s.snapshot.x.rows(), "lamina_sim_positions: xyz");
    copy_points(s.snapshot.x, xyz);
  });
}

lamina_status lamina_sim_embedded_positions(lamina_sim* sim, int32_t k, double* xyz,
                                            int64_t capacity) {
  return guarded([&] {
    lamina_sim& s = need(sim, "lamina_sim_embedded_positions: sim");
    const lamina::EmbeddedSurface& e = need_embedded(&s.model, k, "lamina_sim_embedded_positions");
    need(xyz, "lamina_sim_embedded_positions: xyz");
    need_capacity(capacity, 3 * e.V.rows(), "lamina_sim_embedded_positions: xyz");
    s.embedded_x.resize(s.model.model->embedded.size());
    Eigen::MatrixX3d& out = s.embedded_x[static_cast<size_t>(k)];
    lamina::model::embedded_positions(e, s.snapshot.x, out);
    copy_points(out, xyz);
  });
}

}  // extern "C"
