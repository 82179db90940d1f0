// ThreadSanitizer run over the world loop and its handoff to a viewer (scripts/tsan.sh,
// docs/testing.md). world::WorldLoop steps a world of two organs side by side on its own thread
// while this thread does what the world viewer's frame loop does, as fast as it can: copies the
// latest snapshot, puts live forces on either body by the snapshot's handle and topology (a
// refusal after a cut is expected and counted), sweeps dissections, cuts the first body with a
// scalpel every second across fresh tissue (made on a third thread, taken in and renumbered on
// the loop's: its model and snapshot change size), takes the last cut back now and then, changes
// a body's damping, pauses, changes the rate and resets with a
// cut being made (the uncut body back, the cut dropped; cuts go on after), and drives the hands (a
// tool tip pressed and lifted, a grasper closed and opened on the first body). Any data race is a
// TSan report and a non-zero exit; the program also checks that snapshots advanced, every body's
// positions stayed finite and matched its model, and that the cuts happened.
//   tsan_world_handoff MODEL.vtu [SECONDS]
#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "handoff_setup.h"
#include "lamina/core/error.h"
#include "lamina/world/world_loop.h"

using namespace lamina;

int main(int argc, char** argv) {
  const std::optional<tsan::HandoffSetup> setup = tsan::handoff_setup(argc, argv);
  if (!setup) return 2;
  const double seconds = setup->seconds;
  const sim::Material& material = setup->material;
  const std::shared_ptr<Model> a = setup->model;
  const Eigen::Vector3d lo = a->X.colwise().minCoeff(), hi = a->X.colwise().maxCoeff();
  auto b = std::make_shared<Model>(*a);  // beside it, 1 mm apart along x
  b->X.rowwise() += Eigen::RowVector3d(hi.x() - lo.x() + 1.0, 0.0, 0.0);
  world::World w;
  w.contact.self_contact = false;
  world::create_body(w,
                     {.name = "a", .model = a, .simulation = sim::make_simulation(*a, material)});
  world::create_body(w,
                     {.name = "b", .model = b, .simulation = sim::make_simulation(*b, material)});
  world::WorldLoop loop(std::move(w), {.rate_hz = 2000.0, .publish_interval_s = 0.0});
  loop.start();

  world::WorldSnapshot snap;
  uint64_t frames = 0, fresh = 0, last_generation = 0, refused = 0;
  int cuts_asked = 0, rate_changes = 0, most_cuts = 0, grasps = 0, undos_asked = 0, params_set = 0,
      params_refused = 0;
  bool reset_done = false, tip_on = false, grasping = false;
  double next_dissection = 0.3, next_cut = 0.5, next_pause = 1.0, next_resume = 1.1,
         next_rate = 0.8, next_release = 0.25, next_tip = 0.2, next_grasp = 0.35, next_undo = 1.8,
         next_params = 0.6;
  const auto t0 = std::chrono::steady_clock::now();
  for (;; ++frames) {
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (t > seconds) break;
    if (loop.latest(snap)) {
      ++fresh;
      if (snap.generation <= last_generation) {
        std::fprintf(stderr, "snapshot %llu not newer\n",
                     static_cast<unsigned long long>(snap.generation));
        return 1;
      }
      for (const world::BodyView& v : snap.bodies)
        if (!v.x.allFinite() || !v.model || v.x.rows() != v.model->node_count()) {
          std::fprintf(stderr, "body %s: positions not finite or not its model's\n",
                       v.name.c_str());
          return 1;
        }
      last_generation = snap.generation;
      most_cuts = std::max(most_cuts, snap.cuts);
    }
    if (snap.bodies.size() != 2) continue;
    const world::BodyView& body = snap.bodies[frames % 2];
    const auto node =
        static_cast<int32_t>(frames % static_cast<uint64_t>(body.model->layers[0].node_count));
    try {
      loop.set_forces(body.id, body.topology,
                      {{.node = node, .force_mn = Eigen::Vector3d(0.0, 0.0, 20.0)}});
    } catch (const Error&) {
      ++refused;  // the body was renumbered since this snapshot
    }
    const double x = lo.x() + 0.3 * (hi.x() - lo.x());
    const std::vector<Eigen::Vector3d> path = {Eigen::Vector3d(x, lo.y() - 5, hi.z() + 5),
                                               Eigen::Vector3d(x, hi.y() + 5, hi.z() + 5)};
    // On the wall clock (the frames come far faster than the steps): a dissection every 0.7 s,
    // a cut every second (four), a pause of 0.1 s every 1.5 s, the rate changed every 2.3 s,
    // one reset at 60% of the run (the cut body put back), the forces released every 0.5 s.
    const auto every = [&](double period, double& next) {
      if (t < next) return false;
      next += period;
      return true;
    };
    if (every(0.7, next_dissection)) loop.dissect(path, -Eigen::Vector3d::UnitZ(), 10.0, 2.0);
    // A cut every second, each across fresh tissue (a stroke along an earlier one's path
    // divides nothing more), and one asked just before the reset: the reset meets a cut being
    // made on the loop's other thread, which it drops.
    const bool resetting = !reset_done && t > 0.6 * seconds;
    if (every(1.0, next_cut) || resetting) {
      const double xc = lo.x() + (0.2 + 0.1 * (cuts_asked % 7)) * (hi.x() - lo.x());
      loop.cut({Eigen::Vector3d(xc, lo.y() - 5, hi.z() + 5),
                Eigen::Vector3d(xc, hi.y() + 5, hi.z() + 5)},
               -Eigen::Vector3d::UnitZ(), 0.5 * (hi.z() - lo.z()) + 5.0);
      ++cuts_asked;
    }
    if (every(1.5, next_pause)) loop.set_paused(true);
    if (every(1.5, next_resume)) loop.set_paused(false);
    if (every(2.3, next_rate)) loop.set_rate(++rate_changes % 2 ? 1000.0 : 2000.0);
    if (resetting) {
      loop.reset();
      reset_done = true;
    }
    if (every(0.5, next_release)) loop.clear_forces();
    // The last cut taken back every 2.5 s (on the loop's thread, after a cut being made), and a
    // body's damping changed every 1.7 s (refused when a rate change moved dt since the snapshot).
    if (every(2.5, next_undo)) {
      loop.undo_cut();
      ++undos_asked;
    }
    if (every(1.7, next_params)) {
      const world::BodyView& b = snap.bodies[params_set % 2];
      sim::Material m = b.material;
      m.damping_kg_per_s = params_set % 4 < 2 ? 2.0 * m.damping_kg_per_s + 0.1 : 0.0;
      try {
        loop.set_parameters(b.id, m, b.solver, b.routing);
        ++params_set;
      } catch (const Error&) {
        ++params_refused;
      }
    }
    // A headset's hands: the tip pressed on the first body's top and lifted in turn, the
    // grasper closed on its skin and opened (a close on skin that has moved away is refused).
    const world::BodyView& first = snap.bodies[0];
    Eigen::Index top = 0;
    first.x.topRows(first.model->layers[0].node_count).col(2).maxCoeff(&top);
    const Eigen::Vector3d on_top = first.x.row(top).transpose();
    if (every(0.3, next_tip)) {
      tip_on = !tip_on;
      loop.set_tool_tip({.active = tip_on, .center_mm = on_top + Eigen::Vector3d(0, 0, 3.0)});
    }
    if (every(0.4, next_grasp)) {
      grasping = !grasping;
      try {
        loop.set_grasper(grasping ? std::optional(interact::Jaws{.center_mm = on_top})
                                  : std::nullopt);
        if (grasping) ++grasps;
      } catch (const Error&) {
        grasping = false;
      }
    }
  }
  loop.stop();
  loop.latest(snap);
  std::printf(
      "tsan_world_handoff: %llu viewer frames, %llu fresh snapshots, %lld steps, %d cuts asked, "
      "bodies cut before the reset %d and since %d (%d undos asked, %d undoable at the end), "
      "%llu forces refused as renumbered, %d grasps, parameters set %d times (%d refused)\n",
      static_cast<unsigned long long>(frames), static_cast<unsigned long long>(fresh),
      static_cast<long long>(snap.steps), cuts_asked, most_cuts, snap.cuts, undos_asked,
      snap.undoable, static_cast<unsigned long long>(refused), grasps, params_set, params_refused);
  if (fresh < 10 || snap.steps < 10 || most_cuts == 0 || snap.cuts == 0) {
    std::fprintf(stderr, "too little happened to check anything\n");
    return 1;
  }
  return 0;
}
