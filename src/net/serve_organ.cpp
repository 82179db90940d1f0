// One organ served (net::serve_organ, include/lamina/net/serve.h): the simulation steps in its
// own thread in real time (world::OrganLoop, as in the viewer); this thread only talks to
// the network: tool poses in, the deformed surfaces and the tissue's reaction force out
// (igtl_session.cpp: what each message does and what each tick sends), and the web page's
// session beside it. A client that misbehaves is dropped with a log line and never holds up a
// step.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>

#include "igtl_session.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/sim/simulation.h"
#include "serve_clock.h"
#include "serve_rate.h"
#include "servers.h"
#include "web_session.h"

namespace lamina::net {
namespace {

using Clock = ServeClock;

// This thread's duties until the end: the clients' messages, the reaction every step, the
// embedded surfaces and the layers at their rates, a paused scalpel stroke finished.
void answer_clients(const ServeOptions& a, igtlink::Server& server, IgtlSession& session,
                    web::Session* web_session, Clock::time_point start,
                    const KeepGoing& keep_going) {
  // Sends at send_hz; with send_hz 0 the snapshot is still watched (real time, reaction).
  const auto tick = every(a.send_hz > 0.0 ? a.send_hz : 30.0);
  const auto deadline = start + std::chrono::duration_cast<Clock::duration>(
                                    std::chrono::duration<double>(a.duration_s));
  // The reaction force streams on its own, every step by default (a haptic client's rate); the
  // embedded surfaces, heavier (tens of thousands of triangles), at their own rate.
  const auto reaction_tick = every(std::max(a.reaction_hz, 1e-3));
  const auto embedded_tick = every(std::max(a.embedded_hz, 1e-3));
  auto next_reaction = start, next_embedded = start, next_tick = start;
  while (keep_going()) {
    const auto now = Clock::now();
    if (a.duration_s > 0.0 && now >= deadline) break;
    double wait_s = std::min(seconds(next_tick - now), 0.1);
    if (a.reaction_hz > 0.0) wait_s = std::min(wait_s, seconds(next_reaction - now));
    if (a.embedded_hz > 0.0 && session.has_embedded())
      wait_s = std::min(wait_s, seconds(next_embedded - now));
    wait_s = std::min(wait_s, session.finish_paused_stroke(seconds(now - start)));
    if (a.duration_s > 0.0) wait_s = std::min(wait_s, seconds(deadline - now));
    if (web_session) wait_s = std::min(wait_s, web_session->poll());
    server.poll(
        std::max(wait_s, 0.0), [&](const igtlink::Message& msg) { session.handle(msg); },
        [&](int client) { session.closed(client); });
    if (a.reaction_hz > 0.0 && Clock::now() >= next_reaction) {
      advance(next_reaction, reaction_tick);
      session.stream_reaction();
    }
    if (a.embedded_hz > 0.0 && session.has_embedded() && Clock::now() >= next_embedded) {
      advance(next_embedded, embedded_tick);
      session.stream_embedded();
    }
    if (Clock::now() < next_tick) continue;
    advance(next_tick, tick);
    session.tick();
  }
}

}  // namespace

int serve_organ(Listening& listening, sim::Simulation simulation,
                std::shared_ptr<const Model> model, const interact::RoutingOptions& routing,
                const ServeOptions& a, const std::string& source, const KeepGoing& keep_going) {
  if (!listening.servers || !listening.servers->igtl)
    throw invalid_input(source,
                        "an organ is served over OpenIGTLink: listen with it (a Listening made "
                        "with igtl, not yet served)");
  igtlink::Server& server = *listening.servers->igtl;
  const Model& m = *model;
  ServeRate rate(a.rate_hz, a.auto_rate);
  world::LoopOptions lo;
  lo.rate_hz = rate.rate_hz();  // real time: each step is 1 / rate of simulated time
  lo.threads = a.threads;
  world::OrganLoop loop(model, std::move(simulation), routing, lo);
  const auto start = Clock::now();
  IgtlSession session(a, server, loop, rate, model, start);
  session.log_embedded(false);

  // The web edge shares the tool tip and the grasper, on this thread.
  std::unique_ptr<web::Session> web_session;
  if (listening.servers->web) {
    web_session = std::make_unique<web::Session>(
        std::move(listening.servers->web), web_session_options(a), loop,
        web::SharedTools{session.tip(), session.tool_client(), session.grasper_client()}, model);
  }

  log::info(
      "lamina serve: {} ({} nodes, skin {} nodes and {} triangles, {} layers), {} "
      "in real time; OpenIGTLink on {}:{}{}",
      source, m.node_count(), m.layers[0].node_count, m.layers[0].F.rows(), m.layer_count(),
      a.auto_rate ? fmt::format("{:g} steps/s, then the rate this machine keeps", rate.rate_hz())
                  : fmt::format("{:g} steps/s", rate.rate_hz()),
      a.host, server.port(), a.duration_s > 0.0 ? fmt::format(" for {:g} s", a.duration_s) : "");

  loop.start();
  answer_clients(a, server, session, web_session.get(), start, keep_going);
  loop.stop();
  const int code = session.finish(seconds(Clock::now() - start), web_session.get());
  listening.servers->igtl.reset();  // a Listening serves once: its clients go with the serve
  return code;
}

}  // namespace lamina::net
