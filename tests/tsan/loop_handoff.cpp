// ThreadSanitizer run over the simulation thread and its handoff to a viewer (scripts/tsan.sh,
// docs/testing.md). world::OrganLoop steps on its own thread while another thread does
// what the viewer's frame loop does, as fast as it can: copies the latest snapshot, moves the
// mouse force, pins and releases forces, moves the tool tip, changes parameters (including the
// integrator, which rebuilds the projective solver on the loop's side), pauses, resets,
// changes the rate, cuts the organ (twice: the loop's model and snapshot then change size) and
// undoes the second cut. Any data race is a TSan report and a non-zero exit; the program also
// checks that it saw snapshots advance and that the model stayed finite.
//   tsan_loop_handoff MODEL.vtu [SECONDS]
#include <Eigen/Core>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <string>
#include <thread>

#include "handoff_setup.h"
#include "lamina/core/error.h"
#include "lamina/world/organ_loop.h"

using namespace lamina;

int main(int argc, char** argv) {
  const std::optional<tsan::HandoffSetup> setup = tsan::handoff_setup(argc, argv);
  if (!setup) return 2;
  const Model& model = *setup->model;
  const double seconds = setup->seconds;
  const sim::Material& material = setup->material;
  world::LoopOptions options;
  options.rate_hz = 2000.0;
  options.publish_interval_s = 0.0;  // publish every step: the most handoffs
  world::OrganLoop loop(sim::make_simulation(model, material), {}, options);
  loop.start();

  // The "viewer": a frame loop on this thread.
  const int32_t skin = model.layers[0].node_count;
  world::LoopSnapshot snap;
  uint64_t frames = 0, fresh = 0, last_generation = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (;; ++frames) {
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (t > seconds) break;
    if (loop.latest(snap)) {
      ++fresh;
      if (snap.generation <= last_generation || !snap.x.allFinite() || !snap.model ||
          snap.x.rows() != snap.model->node_count()) {
        std::fprintf(stderr, "snapshot %llu not newer or not finite\n",
                     static_cast<unsigned long long>(snap.generation));
        return 1;
      }
      last_generation = snap.generation;
    }
    const auto node = static_cast<int32_t>(frames % static_cast<uint64_t>(skin));
    switch (frames % 9) {
      case 0:
        loop.set_forces({{node, Eigen::Vector3d(0, 200, 0)}});
        break;
      case 1:
        loop.set_forces({{node, Eigen::Vector3d(0, 150, 0)}, {0, Eigen::Vector3d(50, 0, 0)}});
        break;
      case 2:
        loop.set_forces({});
        break;
      case 3: {
        interact::ToolTip tip;
        tip.active = frames % 2 == 0;
        tip.center_mm = model.X.row(node).transpose();
        loop.set_tool_tip(tip);
        break;
      }
      case 4: {
        sim::SolverOptions solver;
        solver.integrator = static_cast<sim::Integrator>(frames % 3);
        solver.dt_s = 0.005;
        loop.set_parameters(material, solver, {});
        break;
      }
      case 5:
        loop.set_paused(frames % 4 == 1);
        break;
      case 6:
        if (frames % 50 == 6) loop.reset();
        break;
      case 7:
        loop.set_rate(frames % 2 ? 1000.0 : 3000.0);
        if (frames == 1006 || frames == 4003) {  // a plane across the organ, then another
          const Eigen::Vector3d lo = model.X.colwise().minCoeff(),
                                hi = model.X.colwise().maxCoeff();
          const double x = lo.x() + (frames == 1006 ? 0.4 : 0.6) * (hi.x() - lo.x());
          loop.cut({Eigen::Vector3d(x, lo.y() - 5, lo.z() - 5),
                    Eigen::Vector3d(x, hi.y() + 5, lo.z() - 5)},
                   Eigen::Vector3d::UnitZ(), hi.z() - lo.z() + 10);
        }
        if (frames == 5007) loop.undo_cut();  // the second cut taken back
        break;
      default:
        loop.set_paused(false);
        break;
    }
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  loop.stop();
  std::printf(
      "tsan_loop_handoff: %llu viewer frames, %llu fresh snapshots, %lld steps, %lld cuts, "
      "model finite: yes\n",
      static_cast<unsigned long long>(frames), static_cast<unsigned long long>(fresh),
      static_cast<long long>(snap.steps), static_cast<long long>(snap.cuts));
  return fresh > 10 ? 0 : 1;
}
