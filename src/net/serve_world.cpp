// A world served (net::serve_world, include/lamina/net/serve.h): the world steps in its own
// thread in real time (world::WorldLoop), this thread serves its clients.
// OpenIGTLink streams each body's skin and takes the hands (world_igtl_session.h), the web page
// draws every body (world_web_session.h); either or both.

#include <fmt/format.h>

#include <memory>
#include <thread>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/world/world_loop.h"
#include "serve_clock.h"
#include "serve_rate.h"
#include "servers.h"
#include "web_plan.h"
#include "world_igtl_session.h"
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
  // The pages' resection plans, the trees' territories kept per model (web_plan.h).
  auto cache = std::make_shared<web::PlanCache>();
  so.plan = [cache](const Model& m, uint64_t version, const Eigen::MatrixX3d& x,
                    const Eigen::Vector3d& point, const Eigen::Vector3d& normal) {
    return web::plan_reply(m, version, x, point, normal, *cache);
  };
  return so;
}

namespace {

// The network's duties of one turn: the web page's (its frames), OpenIGTLink's (its clients'
// messages, the reaction each step, the skins at send_hz, the embedded surfaces at embedded_hz,
// a paused stroke). Waits on the
// OpenIGTLink server's sockets when there is one, else sleeps: at most until the next duty.
struct WorldEdges {
  const ServeOptions& a;
  ServeClock::time_point start, next_tick, next_reaction, next_embedded;
  std::unique_ptr<web::WorldSession> web = nullptr;
  igtlink::Server* igtl_server = nullptr;
  std::unique_ptr<WorldIgtlSession> igtl = nullptr;

  void turn() {
    using Clock = ServeClock;
    double wait_s = 0.1;
    if (web) wait_s = std::min(wait_s, web->poll());
    if (!igtl) {
      std::this_thread::sleep_for(std::chrono::duration<double>(wait_s));
      return;
    }
    const auto now = Clock::now();
    wait_s = std::min(wait_s, seconds(next_tick - now));
    if (a.reaction_hz > 0.0) wait_s = std::min(wait_s, seconds(next_reaction - now));
    const bool embedded = a.embedded_hz > 0.0 && igtl->has_embedded();
    if (embedded) wait_s = std::min(wait_s, seconds(next_embedded - now));
    wait_s = std::min(wait_s, igtl->finish_paused_stroke(seconds(now - start)));
    igtl_server->poll(
        std::max(wait_s, 0.0), [&](const igtlink::Message& msg) { igtl->handle(msg); },
        [&](int client) { igtl->closed(client); });
    if (a.reaction_hz > 0.0 && Clock::now() >= next_reaction) {
      advance(next_reaction, every(a.reaction_hz));
      igtl->stream_reaction();
    }
    if (embedded && Clock::now() >= next_embedded) {
      advance(next_embedded, every(a.embedded_hz));
      igtl->stream_embedded();
    }
    if (Clock::now() >= next_tick) {
      advance(next_tick, every(a.send_hz > 0.0 ? a.send_hz : 30.0));
      igtl->tick();
    }
  }
};

// The world's name and its bodies', for the first log line.
std::string world_line(const world::WorldSnapshot& snap) {
  std::string names;
  for (const world::BodyView& b : snap.bodies)
    names +=
        fmt::format("{}{} ({} nodes)", names.empty() ? "" : ", ", b.name, b.model->node_count());
  return fmt::format("{}, {} ties", names, snap.tie_count.total);
}

}  // namespace

int serve_world(Listening& listening, world::World world,
                std::vector<world::Dissection> dissections, const ServeOptions& a,
                const std::string& source, const KeepGoing& keep_going) {
  using Clock = ServeClock;
  if (!listening.servers || (!listening.servers->web && !listening.servers->igtl))
    throw invalid_input(source,
                        "nothing listens to serve the world on (a Listening served already)");
  ServeRate rate(a.rate_hz, a.auto_rate);
  world::WorldLoop loop(
      std::move(world),
      {.rate_hz = rate.rate_hz(), .threads = a.threads, .dissections = std::move(dissections)});
  const auto start = Clock::now();
  WorldEdges edges{
      .a = a, .start = start, .next_tick = start, .next_reaction = start, .next_embedded = start};
  if (listening.servers->web)
    edges.web = std::make_unique<web::WorldSession>(std::move(listening.servers->web),
                                                    web_session_options(a), loop);
  if (listening.servers->igtl) {
    edges.igtl_server = listening.servers->igtl.get();
    edges.igtl = std::make_unique<WorldIgtlSession>(a, *edges.igtl_server, loop, rate, start);
    edges.igtl->log_embedded(false);
  }
  world::WorldSnapshot snap;
  loop.latest(snap);
  log::info("lamina serve: world {}: {}; {} in real time{}{}{}", source, world_line(snap),
            a.auto_rate ? "1000 steps/s, then the rate this machine keeps"
                        : fmt::format("{:g} steps/s", rate.rate_hz()),
            edges.igtl ? fmt::format("; OpenIGTLink on {}:{}", a.host, edges.igtl_server->port())
                       : std::string(),
            edges.web ? "; the web page" : "",
            a.duration_s > 0.0 ? fmt::format(" for {:g} s", a.duration_s) : "");
  const auto deadline = start + std::chrono::duration_cast<Clock::duration>(
                                    std::chrono::duration<double>(a.duration_s));
  // A blow-up is said in one error line (at most every 10 s with the count, as a tool held where
  // it blew the world up does it again), the world is reset to rest and the serve goes on, as
  // one organ's does; the exit code says it happened.
  int64_t unstable_events = 0;
  bool awaiting_reset = false;
  auto next_unstable_log = start;
  loop.start();
  while (keep_going()) {
    if (a.duration_s > 0.0 && Clock::now() >= deadline) break;
    edges.turn();
    loop.latest(snap);
    if (snap.unstable == sim::Instability::kNone) {
      awaiting_reset = false;
    } else if (!awaiting_reset) {
      ++unstable_events;
      awaiting_reset = true;
      if (Clock::now() >= next_unstable_log) {
        log::error(
            "body '{}' became unstable at t = {:.3f} s: {}; the world is reset to rest (a lower "
            "--tip-stiffness, a lower --rate or a stiffer material avoids it){}",
            snap.unstable_body, snap.time_s, sim::describe(snap.unstable),
            unstable_events > 1 ? fmt::format(" ({} times so far)", unstable_events) : "");
        next_unstable_log = Clock::now() + std::chrono::seconds(10);
      }
      loop.reset();
      continue;
    }
    // Each wall second: the machine's rate followed, the time behind said (ServeRate::judge).
    const auto second = static_cast<uint64_t>(snap.steps > 0 ? seconds(Clock::now() - start) : 0);
    const ServeRate::Judgement j = rate.judge(snap.rate, second);
    if (j.new_rate) loop.set_rate(*j.new_rate);
    if (j.tell && edges.igtl) edges.igtl->tell_rate(-1);
  }
  loop.stop();
  loop.latest(snap);
  if (edges.web) edges.web->log_summary();
  if (edges.igtl) {
    edges.igtl->log_embedded(true);
    edges.igtl->log_summary(seconds(Clock::now() - start));
  }
  listening.servers->igtl.reset();  // a Listening serves once
  const double wall_s = seconds(Clock::now() - start);
  log::info(
      "lamina serve: {} steps, {:.2f} s simulated in {:.2f} s ({:.2f}x real time, {:.0f} s "
      "behind, last at {:g} steps/s chosen by the {}); {} of {} ties divided, {} torn",
      snap.steps, snap.time_s, wall_s, wall_s > 0.0 ? snap.time_s / wall_s : 0.0, rate.behind_s(),
      rate.rate_hz(), rate.chosen_by(), snap.tie_count.divided, snap.tie_count.total,
      snap.tie_count.torn);
  if (unstable_events > 0) {
    log::error("the world became unstable {} time(s) during the session (see above)",
               unstable_events);
    return static_cast<int>(ErrorKind::kUnstable);
  }
  return 0;
}

}  // namespace lamina::net
