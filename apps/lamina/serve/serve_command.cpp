// `lamina serve`: the simulation as an OpenIGTLink server, the way 3D Slicer's OpenIGTLinkIF
// connects to one (docs/openigtlink.md). The simulation steps in its own thread in real time
// (interact::RealtimeLoop, as in the viewer); this thread only talks to the network: tool poses
// in, the deformed surfaces and the tissue's reaction force out (igtl_session.cpp: what each
// message does and what each tick sends). A client that misbehaves is dropped with a log line
// and never holds up a step.
#include <arpa/inet.h>
#include <fmt/format.h>
#include <ifaddrs.h>
#include <netinet/in.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>

#include "commands.h"
#include "igtl_server.h"
#include "igtl_session.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/interact/realtime_loop.h"
#include "lamina/io/scene.h"
#include "lamina/io/world_scene.h"
#include "lamina/sim/simulation.h"
#include "serve_rate.h"
#include "web_session.h"
#include "web_tls.h"
#include "world_serve.h"

namespace lamina::cli {
namespace {

using Clock = ServeClock;

std::atomic<bool> stop_requested{false};
void request_stop(int) {
  stop_requested = true;
}

// Ctrl-C and SIGTERM end the serve loop, which then stops the simulation and logs its summary.
void install_stop_signals() {
  struct sigaction action {};
  action.sa_handler = request_stop;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

void check_args(const ServeArgs& a) {
  if (!(a.send_hz >= 0.0 && a.send_hz <= 1000.0))
    throw invalid_input("--send-hz", "must be in [0, 1000] messages per second");
  if (!(a.embedded_hz >= 0.0 && a.embedded_hz <= 1000.0))
    throw invalid_input("--embedded-hz", "must be in [0, 1000] messages per second");
  if (!(a.reaction_hz >= 0.0 && a.reaction_hz <= 1e5))
    throw invalid_input("--reaction-hz", "must be in [0, 1e5] messages per second");
  if (!(a.rate_hz > 0.0 && a.rate_hz <= 1e5))
    throw invalid_input("--rate", "must be in (0, 1e5] steps per second");
  if (!(a.duration_s >= 0.0)) throw invalid_input("--duration", "must be >= 0 s");
  if (a.frame != "ras" && a.frame != "lps")
    throw invalid_input("--frame", "must be ras or lps, got '" + a.frame + "'");
  if (!a.grasper_device.empty() && a.grasper_device == a.tool_device)
    throw invalid_input("--grasper-device",
                        "is also --tool-device ('" + a.tool_device + "'): give them two names");
  if (!(a.grasper_radius_mm > 0.0 && a.grasper_radius_mm <= 100.0))
    throw invalid_input("--grasper-radius", "must be in (0, 100] mm");
  for (const std::string* other : {&a.tool_device, &a.grasper_device})
    if (!a.scalpel_device.empty() && a.scalpel_device == *other)
      throw invalid_input("--scalpel-device", "is also the tool's or the grasper's device ('" +
                                                  a.scalpel_device + "'): give each its own name");
  if (!(a.scalpel_depth_mm > 0.0 && a.scalpel_depth_mm <= 200.0))
    throw invalid_input("--scalpel-depth", "must be in (0, 200] mm");
  if (!(a.scalpel_pause_s > 0.0 && a.scalpel_pause_s <= 60.0))
    throw invalid_input("--scalpel-pause", "must be in (0, 60] s");
  if (!(a.tip_radius_mm > 0.0 && a.tip_radius_mm <= 100.0))
    throw invalid_input("--tip-radius", "must be in (0, 100] mm");
  if (!(a.tip_stiffness_n_per_m > 0.0 && a.tip_stiffness_n_per_m <= 1e4))
    throw invalid_input("--tip-stiffness", "must be in (0, 1e4] N/m");
  if (!(a.max_force_n > 0.0 && a.max_force_n <= 100.0))
    throw invalid_input("--max-force", "must be in (0, 100] N (what a haptic device is sent)");
  if (!(a.max_message_mb > 0.0 && a.max_message_mb <= 1024.0))
    throw invalid_input("--max-message-mb", "must be in (0, 1024] MB");
  if (!(a.stall_timeout_s > 0.0)) throw invalid_input("--stall-timeout", "must be > 0 s");
  if (a.max_clients < 1) throw invalid_input("--max-clients", "must be >= 1");
  if (a.threads < 0) throw invalid_input("--threads", "must be >= 0 (0 = OpenMP's default)");
  if (!(a.web_hz > 0.0 && a.web_hz <= 240.0))
    throw invalid_input("--web-hz", "must be in (0, 240] frames per second");
  if (a.web_port < 0 || a.web_port > 65535)
    throw invalid_input("--web-port", "must be in [0, 65535]");
  if (!(a.gain_n_per_mm > 0.0 && a.gain_n_per_mm <= 1.0))
    throw invalid_input("--gain", "must be in (0, 1] N/mm");
  if (a.self_signed && (!a.cert.empty() || !a.key.empty()))
    throw invalid_input("--self-signed", "give either --self-signed or --cert and --key");
  if (a.cert.empty() != a.key.empty())
    throw invalid_input(a.cert.empty() ? "--key" : "--cert", "needs the other: --cert and --key");
  if ((a.self_signed || !a.cert.empty()) && !a.web)
    throw invalid_input(a.self_signed ? "--self-signed" : "--cert",
                        "is for the web server: add --web");
  for (const char c : a.web_token)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_')
      throw invalid_input("--token", "may hold letters, digits, '-' and '_' only");
}

// The addresses a client may reach the web server by: the one it listens on, or for 0.0.0.0
// every IPv4 address of this machine, and its host name.
std::vector<std::string> local_addresses(const std::string& listen) {
  std::vector<std::string> out;
  if (listen != "0.0.0.0") return {listen};
  char name[256] = {};
  if (gethostname(name, sizeof name - 1) == 0 && name[0] != '\0') out.emplace_back(name);
  ifaddrs* list = nullptr;
  if (getifaddrs(&list) == 0) {
    for (const ifaddrs* i = list; i != nullptr; i = i->ifa_next) {
      if (i->ifa_addr == nullptr || i->ifa_addr->sa_family != AF_INET) continue;
      char text[INET_ADDRSTRLEN] = {};
      inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(i->ifa_addr)->sin_addr, text,
                sizeof text);
      out.emplace_back(text);
    }
    freeifaddrs(list);
  }
  return out;
}

// The page's files: --web-root, or web/ beside the lamina binary (the build's), or the
// installed share/lamina/web.
std::string web_root(const ServeArgs& a) {
  namespace fs = std::filesystem;
  std::vector<fs::path> tried;
  if (!a.web_root.empty()) {
    tried.push_back(a.web_root);
  } else {
    const fs::path exe = fs::canonical("/proc/self/exe").parent_path();
    tried = {exe / "web", exe.parent_path() / "share" / "lamina" / "web"};
  }
  for (const fs::path& p : tried)
    if (fs::exists(p / "index.html") && fs::exists(p / "vendor" / "three" / "three.module.js"))
      return p.string();
  throw invalid_input(a.web_root.empty() ? "--web" : "--web-root",
                      "the page's files are not at " + tried.front().string() +
                          " (index.html and vendor/three): build with npm present "
                          "(scripts/setup.sh installs it), or give --web-root");
}

// The web edge (--web): its own server beside OpenIGTLink's, with its TLS identity.
std::unique_ptr<web::Server> start_web(const ServeArgs& a) {
  web::ServerOptions wo;
  wo.host = a.web_host;
  wo.port = a.web_port;
  wo.token = a.web_token;
  wo.root = web_root(a);
  wo.max_clients = a.max_clients;
  wo.stall_timeout_s = std::max(a.stall_timeout_s, 2.0);
  if (!a.cert.empty()) {
    wo.tls = web::read_identity(a.cert, a.key);
  } else if (a.self_signed) {
    // Named for this machine and every address a headset may reach it by.
    std::vector<std::string> hosts = {"localhost", "127.0.0.1"};
    for (const std::string& h : local_addresses(a.web_host))
      if (std::find(hosts.begin(), hosts.end(), h) == hosts.end()) hosts.push_back(h);
    wo.tls = web::self_signed_identity(hosts);
  }
  auto server = std::make_unique<web::Server>(wo);
  if (wo.tls)
    log::info("web: TLS with {} (certificate SHA-256 {}){}", wo.tls->source,
              wo.tls->fingerprint_sha256,
              a.self_signed ? "; a browser warns of a certificate it does not know: compare "
                              "the fingerprint, then accept it"
                            : "");
  log::info("web: listening on {}:{}; the page is at {}", a.web_host, server->port(),
            server->url());
  return server;
}

}  // namespace

int run_serve(const ServeArgs& a) {
  check_args(a);
  if (io::is_world_scene_file(a.what)) {
    if (a.paper)
      throw invalid_input("--paper", "cannot be given with a world scene (" + a.what + ")");
    if (!a.web)
      throw invalid_input(a.what,
                          "a world scene is served to the web page only: add --web "
                          "(OpenIGTLink streams one organ's surfaces)");
    std::unique_ptr<web::Server> web_server = start_web(a);  // a port in use fails at once
    install_stop_signals();
    return run_world_serve(a, std::move(web_server), stop_requested);
  }
  io::Scene scene = io::scene_for(a.what, a.paper);
  // The tool comes over the network; a scene's own tools would push on their own.
  if (!scene.tools.empty())
    log::info("{}: its {} tools are not used: the tool is driven over OpenIGTLink", scene.source,
              scene.tools.size());
  scene.tools.clear();
  scene.default_tool = false;
  // Listening first: a port in use fails before the model is built. Clients that connect
  // meanwhile wait in the listen queue.
  net::ServerOptions so;
  so.host = a.host;
  so.port = a.port;
  so.max_body_bytes = static_cast<uint64_t>(a.max_message_mb * (1 << 20));
  so.stall_timeout_s = a.stall_timeout_s;
  so.max_clients = a.max_clients;
  net::Server server(so);
  log::info("listening on {}:{}", a.host, server.port());
  std::unique_ptr<web::Server> web_server = a.web ? start_web(a) : nullptr;
  const io::ReadyScene ready =
      io::make_ready_scene(scene, volume_read_options, stderr_progress(a.verbose));
  scene = ready.scene;
  io::warn_scalpels_ignored(scene);
  const Model& m = *ready.model;
  ServeRate rate(a.rate_hz, a.auto_rate);
  interact::LoopOptions lo;
  lo.rate_hz = rate.rate_hz();  // real time: each step is 1 / rate of simulated time
  lo.threads = a.threads;
  interact::RealtimeLoop loop(io::make_scene_simulation(ready), scene.routing, lo);
  const auto start = Clock::now();
  IgtlSession session(a, server, loop, rate, ready.model, start);
  session.log_embedded(false);

  // The web edge shares the tool tip and the grasper, on this thread.
  std::unique_ptr<web::Session> web_session;
  if (web_server) {
    web_session = std::make_unique<web::Session>(
        std::move(web_server), web_session_options(a), loop,
        web::SharedTools{session.tip(), session.tool_client(), session.grasper_client()},
        ready.model);
  }

  install_stop_signals();

  log::info(
      "lamina serve: {} ({} nodes, skin {} nodes and {} triangles, {} layers), {} "
      "in real time; OpenIGTLink on {}:{}{}",
      ready.source, m.node_count(), m.layers[0].node_count, m.layers[0].F.rows(), m.layer_count(),
      a.auto_rate ? fmt::format("{:g} steps/s, then the rate this machine keeps", rate.rate_hz())
                  : fmt::format("{:g} steps/s", rate.rate_hz()),
      a.host, server.port(), a.duration_s > 0.0 ? fmt::format(" for {:g} s", a.duration_s) : "");

  // Sends at send_hz; with --send-hz 0 the snapshot is still watched (real time, reaction).
  const auto every = [](double hz) {
    return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / hz));
  };
  const auto tick = every(a.send_hz > 0.0 ? a.send_hz : 30.0);
  const auto deadline = start + std::chrono::duration_cast<Clock::duration>(
                                    std::chrono::duration<double>(a.duration_s));
  // The reaction force streams on its own, every step by default (a haptic client's rate); the
  // embedded surfaces, heavier (tens of thousands of triangles), at their own rate.
  const auto reaction_tick = every(std::max(a.reaction_hz, 1e-3));
  const auto embedded_tick = every(std::max(a.embedded_hz, 1e-3));
  auto next_reaction = start, next_embedded = start, next_tick = start;
  // The next time of a periodic duty, without a burst after a stall.
  const auto advance = [](Clock::time_point& next, Clock::duration period) {
    next += period;
    if (next < Clock::now()) next = Clock::now() + period;
  };
  loop.start();
  while (!stop_requested) {
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
        std::max(wait_s, 0.0), [&](const net::Message& msg) { session.handle(msg); },
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
  loop.stop();
  return session.finish(seconds(Clock::now() - start), web_session.get());
}

}  // namespace lamina::cli
