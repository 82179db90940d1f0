// A world served (net::serve_world, include/lamina/net/serve.h): the world steps in its own
// thread in real time (world::WorldLoop), this thread serves the page (web::WorldSession).
// OpenIGTLink streams one organ's surfaces and takes one tool, so a world is served to the web
// page only.

#include <fmt/format.h>

#include <thread>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/interact/rate_choice.h"
#include "lamina/world/world_loop.h"
#include "serve_clock.h"
#include "servers.h"
#include "world_web_session.h"

namespace lamina::net {

web::SessionOptions web_session_options(const ServeOptions& a) {
  web::SessionOptions so;
  so.frame_hz = a.web_hz;
  so.gain_n_per_mm = a.gain_n_per_mm;
  so.tip.radius_mm = a.tip_radius_mm;
  so.tip.stiffness_n_per_m = a.tip_stiffness_n_per_m;
  so.tip.max_force_n = a.max_force_n;
  so.hello_fields = {{"max_force_mn", 1000.0 * a.max_force_n},
                     {"tip_radius_mm", a.tip_radius_mm},
                     {"grasp_radius_mm", so.grasp_radius_mm},
                     {"frame_hz", a.web_hz}};
  return so;
}

int serve_world(Listening& listening, world::World world,
                std::vector<world::Dissection> dissections, const ServeOptions& a,
                const std::string& source, const KeepGoing& keep_going) {
  using Clock = ServeClock;
  if (!listening.servers || !listening.servers->web)
    throw invalid_input(source, "a world is served to the web page: listen with the web on");
  double rate_hz = a.auto_rate ? 1000.0 : a.rate_hz;
  world::WorldLoop loop(
      std::move(world),
      {.rate_hz = rate_hz, .threads = a.threads, .dissections = std::move(dissections)});
  web::WorldSession session(std::move(listening.servers->web), web_session_options(a), loop);
  world::WorldSnapshot snap;
  loop.latest(snap);
  std::string names;
  for (const world::BodyView& b : snap.bodies)
    names +=
        fmt::format("{}{} ({} nodes)", names.empty() ? "" : ", ", b.name, b.model->node_count());
  log::info(
      "lamina serve: world {}: {}, {} ties; {} in real time, on the web page only "
      "(OpenIGTLink streams one organ){}",
      source, names, snap.tie_count.total,
      a.auto_rate ? "1000 steps/s, then the rate this machine keeps"
                  : fmt::format("{:g} steps/s", rate_hz),
      a.duration_s > 0.0 ? fmt::format(" for {:g} s", a.duration_s) : "");
  const auto start = Clock::now();
  const auto deadline = start + std::chrono::duration_cast<Clock::duration>(
                                    std::chrono::duration<double>(a.duration_s));
  bool behind_said = false;
  uint64_t judged = 0;  // the snapshot generation the rate was last judged on
  loop.start();
  while (keep_going()) {
    if (a.duration_s > 0.0 && Clock::now() >= deadline) break;
    const double wait_s = session.poll();
    loop.latest(snap);
    if (snap.unstable != sim::Instability::kNone) break;
    if (a.auto_rate && snap.generation != judged && seconds(Clock::now() - start) >= 2.0) {
      judged = snap.generation;
      if (const auto next = interact::rate_to_follow(rate_hz, snap.rate, "--rate")) {
        rate_hz = *next;
        loop.set_rate(rate_hz);
      }
    }
    if (!snap.rate.keeping_up && !behind_said) {
      behind_said = true;
      log::warn(
          "real time: the world ran at {:.2f}x of the wall clock at {:g} Hz (a step "
          "{:.2f} ms)",
          snap.rate.real_time_factor, rate_hz, snap.rate.mean_step_us / 1000.0);
    }
    std::this_thread::sleep_for(std::chrono::duration<double>(wait_s));
  }
  loop.stop();
  loop.latest(snap);
  session.log_summary();
  log::info(
      "lamina serve: {} steps, {:.2f} s simulated in {:.2f} s; {} of {} ties divided, {} "
      "torn",
      snap.steps, snap.time_s, seconds(Clock::now() - start), snap.tie_count.divided,
      snap.tie_count.total, snap.tie_count.torn);
  if (snap.unstable != sim::Instability::kNone) {
    log::error("lamina serve: body '{}' became unstable at t = {:.3f} s: {}", snap.unstable_body,
               snap.time_s, sim::describe(snap.unstable));
    return static_cast<int>(ErrorKind::kUnstable);
  }
  return 0;
}

}  // namespace lamina::net
