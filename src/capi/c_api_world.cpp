// The C API's worlds (include/lamina/c_api.h, "worlds"): a world scene made ready and stepped by
// a world::WorldLoop on the caller's thread (run_steps: no thread, no clock), its bodies named by
// their index in the scene.
#include <fmt/format.h>

#include <memory>
#include <string>
#include <vector>

#include "c_api_support.h"
#include "lamina/io/scene_model.h"
#include "lamina/io/world_scene.h"
#include "lamina/sim/simulation.h"
#include "lamina/world/world_loop.h"

struct lamina_world {
  std::unique_ptr<lamina::world::WorldLoop> loop;
  lamina::world::WorldSnapshot snapshot;  // after the last call that stepped or changed it
  std::vector<lamina_model> models;       // per body, the handles lamina_world_body_model gives
};

namespace {

using lamina::capi::guarded;
using lamina::capi::need;

const lamina::world::BodyView& need_body(const lamina_world& w, int32_t body, const char* what) {
  if (body < 0 || static_cast<size_t>(body) >= w.snapshot.bodies.size())
    throw lamina::invalid_input(
        what, fmt::format("body {} is out of range: the world has {} "
                          "(0..{})",
                          body, w.snapshot.bodies.size(), w.snapshot.bodies.size() - 1));
  return w.snapshot.bodies[static_cast<size_t>(body)];
}

// Steps the world `steps` steps (0: only the commands given since are taken) and keeps the
// snapshot the other calls read; a body cut (or put back uncut) is described by its handle's
// model from now on.
void advance(lamina_world& w, int64_t steps) {
  w.loop->run_steps(steps);
  w.loop->latest(w.snapshot);
  for (size_t b = 0; b < w.models.size() && b < w.snapshot.bodies.size(); ++b)
    w.models[b].model = w.snapshot.bodies[b].model;
}

// A blade's upper end: `points` points, interleaved.
std::vector<Eigen::Vector3d> blade_path(const double* path_xyz, int32_t points,
                                        const std::string& what) {
  if (points < 2) throw lamina::invalid_input(what + ": points", "must be >= 2");
  need(path_xyz, (what + ": path_xyz").c_str());
  std::vector<Eigen::Vector3d> path;
  for (int32_t k = 0; k < points; ++k)
    path.emplace_back(path_xyz[3 * k], path_xyz[3 * k + 1], path_xyz[3 * k + 2]);
  return path;
}

}  // namespace

extern "C" {

lamina_status lamina_world_create_from_scene(const char* scene, lamina_world** out) {
  return guarded([&] {
    need(out, "lamina_world_create_from_scene: out") = nullptr;
    const std::string path =
        lamina::capi::need_text(scene, "lamina_world_create_from_scene: scene");
    if (!lamina::io::is_world_scene_file(path))
      throw lamina::invalid_input(path,
                                  "is not a world scene (a .json with \"bodies\"); "
                                  "lamina_sim_create_from_scene takes one organ's");
    const lamina::io::WorldScene s = lamina::io::load_world_scene(path);
    std::unique_ptr<lamina::io::ReadyWorld> ready =
        lamina::io::make_ready_world(s, lamina::io::ReadVolumeOptions{});
    auto w = std::make_unique<lamina_world>();
    w->loop = std::make_unique<lamina::world::WorldLoop>(
        std::move(ready->world),
        lamina::world::WorldLoopOptions{
            .rate_hz = 0.0, .real_time = false, .dissections = s.dissections});
    advance(*w, 0);
    for (const lamina::world::BodyView& b : w->snapshot.bodies) w->models.push_back({b.model});
    *out = w.release();
  });
}

void lamina_world_free(lamina_world* world) {
  delete world;
}

int32_t lamina_world_body_count(const lamina_world* world) {
  return world == nullptr ? 0 : static_cast<int32_t>(world->snapshot.bodies.size());
}

const char* lamina_world_body_name(const lamina_world* world, int32_t body) {
  if (world == nullptr || body < 0 || body >= lamina_world_body_count(world)) return nullptr;
  return world->snapshot.bodies[static_cast<size_t>(body)].name.c_str();
}

const lamina_model* lamina_world_body_model(const lamina_world* world, int32_t body) {
  if (world == nullptr || body < 0 || body >= lamina_world_body_count(world)) return nullptr;
  return &world->models[static_cast<size_t>(body)];
}

lamina_status lamina_world_body_positions(const lamina_world* world, int32_t body, double* xyz,
                                          int64_t capacity) {
  return guarded([&] {
    const lamina_world& w = need(world, "lamina_world_body_positions: world");
    const lamina::world::BodyView& b = need_body(w, body, "lamina_world_body_positions");
    need(xyz, "lamina_world_body_positions: xyz");
    lamina::capi::need_capacity(capacity, 3 * b.x.rows(), "lamina_world_body_positions: xyz");
    lamina::capi::copy_points(b.x, xyz);
  });
}

lamina_status lamina_world_set_forces(lamina_world* world, int32_t body, const int32_t* skin_nodes,
                                      const double* forces_mn, int32_t count) {
  return guarded([&] {
    lamina_world& w = need(world, "lamina_world_set_forces: world");
    const lamina::world::BodyView& b = need_body(w, body, "lamina_world_set_forces");
    if (count < 0) throw lamina::invalid_input("lamina_world_set_forces: count", "is negative");
    std::vector<lamina::interact::LiveForce> forces;
    if (count > 0) {
      need(skin_nodes, "lamina_world_set_forces: skin_nodes");
      need(forces_mn, "lamina_world_set_forces: forces_mn");
      lamina::capi::need_finite(forces_mn, 3 * count, "lamina_world_set_forces: forces_mn");
    }
    for (int32_t k = 0; k < count; ++k)
      forces.push_back(
          {.node = skin_nodes[k],
           .force_mn = {forces_mn[3 * k], forces_mn[3 * k + 1], forces_mn[3 * k + 2]}});
    w.loop->set_forces(b.id, b.topology, std::move(forces));  // checks the nodes
    advance(w, 0);
  });
}

lamina_status lamina_world_dissect(lamina_world* world, const double* path_xyz, int32_t points,
                                   const double direction[3], double depth_mm, double reach_mm,
                                   int32_t* divided) {
  return guarded([&] {
    lamina_world& w = need(world, "lamina_world_dissect: world");
    std::vector<Eigen::Vector3d> path = blade_path(path_xyz, points, "lamina_world_dissect");
    need(direction, "lamina_world_dissect: direction");
    const int32_t before = w.snapshot.ties_divided_by_strokes;
    w.loop->dissect(std::move(path), Eigen::Vector3d(direction[0], direction[1], direction[2]),
                    depth_mm, reach_mm);
    advance(w, 0);
    if (divided != nullptr) *divided = w.snapshot.ties_divided_by_strokes - before;
  });
}

lamina_status lamina_world_cut(lamina_world* world, const double* path_xyz, int32_t points,
                               const double direction[3], double depth_mm, int64_t* tets_divided) {
  return guarded([&] {
    lamina_world& w = need(world, "lamina_world_cut: world");
    std::vector<Eigen::Vector3d> path = blade_path(path_xyz, points, "lamina_world_cut");
    need(direction, "lamina_world_cut: direction");
    const int64_t before = w.snapshot.tets_cut;
    w.loop->cut(std::move(path), Eigen::Vector3d(direction[0], direction[1], direction[2]),
                depth_mm);
    advance(w, 0);
    if (tets_divided != nullptr) *tets_divided = w.snapshot.tets_cut - before;
  });
}

lamina_status lamina_world_undo_cut(lamina_world* world) {
  return guarded([&] {
    lamina_world& w = need(world, "lamina_world_undo_cut: world");
    if (w.snapshot.undoable == 0)
      throw lamina::invalid_input("lamina_world_undo_cut", "there is no cut to undo");
    w.loop->undo_cut();
    advance(w, 0);
  });
}

uint32_t lamina_world_body_topology(const lamina_world* world, int32_t body) {
  if (world == nullptr || body < 0 || body >= lamina_world_body_count(world)) return 0;
  return world->snapshot.bodies[static_cast<size_t>(body)].topology;
}

lamina_status lamina_world_step(lamina_world* world, int32_t steps, lamina_world_stats* stats) {
  return guarded([&] {
    lamina_world& w = need(world, "lamina_world_step: world");
    if (steps < 0) throw lamina::invalid_input("lamina_world_step: steps", "is negative");
    advance(w, steps);
    const lamina::world::WorldSnapshot& s = w.snapshot;
    if (s.unstable != lamina::sim::Instability::kNone)
      throw lamina::Error(
          lamina::ErrorKind::kUnstable,
          fmt::format("lamina_world_step: body '{}' unstable at t = {:.3f} s: {}; "
                      "lower dt, the forces or the stiffness, then "
                      "lamina_world_reset",
                      s.unstable_body, s.time_s, lamina::sim::describe(s.unstable)));
    if (stats == nullptr) return;
    *stats = {};
    stats->time_s = s.time_s;
    stats->steps = s.steps;
    for (const lamina::world::BodyView& b : s.bodies) {
      stats->max_displacement_mm =
          std::max(stats->max_displacement_mm, b.stats.sim.max_displacement_mm);
      stats->max_penetration_mm = std::max(stats->max_penetration_mm, b.stats.max_penetration_mm);
    }
    stats->ties = s.tie_count.total;
    stats->ties_divided = s.tie_count.divided;
    stats->ties_torn = s.tie_count.torn;
    stats->at_rest = s.converged ? 1 : 0;
    stats->contact_us = s.profile.contact_us;
    stats->step_us = s.step_us;
  });
}

lamina_status lamina_world_reset(lamina_world* world) {
  return guarded([&] {
    lamina_world& w = need(world, "lamina_world_reset: world");
    w.loop->reset();
    advance(w, 0);
  });
}

}  // extern "C"
