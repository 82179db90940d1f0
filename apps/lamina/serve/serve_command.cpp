// `lamina serve`: the simulation as an OpenIGTLink server, the way 3D Slicer's OpenIGTLinkIF
// connects to one (docs/openigtlink.md). The simulation steps in its own thread in real time
// (interact::RealtimeLoop, as in the viewer); this thread only talks to the network: tool poses
// in, the deformed surfaces and the tissue's reaction force out. A client that misbehaves is
// dropped with a log line and never holds up a step.
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
#include <set>

#include "commands.h"
#include "igtl_server.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/interact/realtime_loop.h"
#include "lamina/io/scene.h"
#include "lamina/model/embed_surface.h"
#include "lamina/sim/simulation.h"
#include "scalpel_stroke.h"
#include "serve_rate.h"
#include "web_session.h"
#include "web_tls.h"

namespace lamina::cli {
namespace {

using Clock = std::chrono::steady_clock;

std::atomic<bool> stop_requested{false};
void request_stop(int) {
  stop_requested = true;
}

double seconds(Clock::duration d) {
  return std::chrono::duration<double>(d).count();
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

// The device name of layer k's POLYDATA: LaminaSkin for the skin, LaminaLayer1... inside.
std::string layer_device(int32_t k) {
  return k == 0 ? "LaminaSkin" : "LaminaLayer" + std::to_string(k);
}

// OpenIGTLink's device names hold at most this many characters.
constexpr size_t kMaxDeviceName = 20;

// Turns the simulation's snapshot into messages: the layers' (LaminaSkin, LaminaLayerK) and the
// embedded surfaces' (named as in the model), each packer laid out once with its triangles.
class Outgoing {
 public:
  Outgoing(std::shared_ptr<const Model> model, net::Frame frame)
      : shared_(std::move(model)), model_(*shared_), frame_(frame) {
    const Model& m = model_;
    for (int32_t k = 0; k < m.layer_count(); ++k) {
      const ModelLayer& layer = m.layers[static_cast<size_t>(k)];
      // The model's triangles index every node; a message indexes its own points.
      const Eigen::MatrixX3i F = layer.F.array() - layer.first_node;
      layers_.emplace_back(layer_device(k), F, layer.node_count);
    }
    for (const EmbeddedSurface& e : m.embedded) {
      // A name the wire cannot carry, or one that another message already has, would reach a
      // client as some other surface: said, and that surface is not sent.
      const bool taken = e.name == kReactionDevice || requested_layer(e.name) > 0 ||
                         e.name == layer_device(0) || find_embedded(e.name) >= 0;
      if (e.name.empty() || e.name.size() > kMaxDeviceName || taken) {
        log::warn(
            "the embedded surface '{}' is not sent over OpenIGTLink: {} (rename it in the "
            "scene's build.embed)",
            e.name,
            taken ? "another message has that device name"
                  : fmt::format("a device name has 1 to {} characters", kMaxDeviceName));
        continue;
      }
      embedded_.push_back({&e, net::PolyDataPacker(e.name, e.F, static_cast<int32_t>(e.V.rows())),
                           Eigen::MatrixX3d()});
    }
  }

  // A GET_POLYDATA names a layer (LaminaLayerK) or an embedded surface; any other name means the
  // skin (the protocol's example client asks as "Client").
  net::Packed requested(const interact::LoopSnapshot& snap, const std::string& device) {
    const int32_t e = find_embedded(device);
    return e >= 0 ? embedded(snap, e) : layer(snap, requested_layer(device));
  }

  net::Packed layer(const interact::LoopSnapshot& snap, int32_t k) {
    const ModelLayer& l = model_.layers[static_cast<size_t>(k)];
    return layers_[static_cast<size_t>(k)].pack(snap.x.middleRows(l.first_node, l.node_count),
                                                frame_);
  }

  // The embedded surface's points W x; its buffers are kept from one frame to the next.
  net::Packed embedded(const interact::LoopSnapshot& snap, int32_t e) {
    Embedded& out = embedded_[static_cast<size_t>(e)];
    const auto t0 = Clock::now();
    model::embedded_positions(*out.surface, snap.x, out.points);
    net::Packed message = out.packer.pack(out.points, frame_);
    out.pack_s += seconds(Clock::now() - t0);
    ++out.packs;
    return message;
  }
  int32_t embedded_count() const { return static_cast<int32_t>(embedded_.size()); }

  net::Packed reaction(const Eigen::Vector3d& reaction_mn) const {
    return net::pack_transform(kReactionDevice, net::change_frame(reaction_mn, frame_));
  }

  // One line per embedded surface sent: its size on the wire and what a frame of it cost.
  void log_embedded(bool at_exit) const {
    for (const Embedded& e : embedded_) {
      if (at_exit && e.packs == 0) continue;
      const std::string cost =
          at_exit ? fmt::format(", {:.2f} ms per message to compute and pack ({} messages)",
                                1e3 * e.pack_s / static_cast<double>(e.packs), e.packs)
                  : "";
      log::info("POLYDATA '{}': {} points, {} triangles, {:.0f} kB a message{}", e.packer.device(),
                e.surface->V.rows(), e.surface->F.rows(),
                static_cast<double>(e.packer.message_bytes()) / 1e3, cost);
    }
  }

  static constexpr const char* kReactionDevice = "LaminaReaction";

 private:
  struct Embedded {
    const EmbeddedSurface* surface;
    net::PolyDataPacker packer;
    Eigen::MatrixX3d points;  // W x, mm, LPS
    double pack_s = 0.0;      // time spent on W x and packing, s
    int64_t packs = 0;
  };

  int32_t requested_layer(const std::string& device) const {
    for (int32_t k = 1; k < model_.layer_count(); ++k)
      if (device == layer_device(k)) return k;
    return 0;
  }
  int32_t find_embedded(const std::string& device) const {
    for (size_t e = 0; e < embedded_.size(); ++e)
      if (embedded_[e].packer.device() == device) return static_cast<int32_t>(e);
    return -1;
  }

  std::shared_ptr<const Model> shared_;  // a cut replaces the loop's: kept while sent
  const Model& model_;
  net::Frame frame_;
  std::vector<net::PolyDataPacker> layers_;
  std::vector<Embedded> embedded_;
};

}  // namespace

int run_serve(const ServeArgs& a) {
  check_args(a);
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
  std::unique_ptr<web::Server> web_server;
  if (a.web) {
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
    web_server = std::make_unique<web::Server>(wo);
    if (wo.tls)
      log::info("web: TLS with {} (certificate SHA-256 {}){}", wo.tls->source,
                wo.tls->fingerprint_sha256,
                a.self_signed ? "; a browser warns of a certificate it does not know: compare "
                                "the fingerprint, then accept it"
                              : "");
    log::info("web: listening on {}:{}; the page is at {}", a.web_host, web_server->port(),
              web_server->url());
  }
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
  const net::Frame frame = a.frame == "lps" ? net::Frame::kLps : net::Frame::kRas;
  // What is sent is laid out for a model; a cut makes another (and adds the wound), which the
  // snapshots then carry: each message is packed for the model of the snapshot it shows.
  auto outgoing = std::make_unique<Outgoing>(ready.model, frame);
  uint64_t outgoing_version = 0;
  const auto sent_for = [&](const interact::LoopSnapshot& sn) -> Outgoing& {
    if (sn.model && sn.model_version != outgoing_version) {
      outgoing = std::make_unique<Outgoing>(sn.model, frame);
      outgoing_version = sn.model_version;
    }
    return *outgoing;
  };
  const int32_t streamed_layers = a.all_layers ? m.layer_count() : 1;
  outgoing->log_embedded(false);
  ScalpelStroke stroke;

  interact::ToolTip tip;
  tip.radius_mm = a.tip_radius_mm;
  tip.stiffness_n_per_m = a.tip_stiffness_n_per_m;
  tip.max_force_n = a.max_force_n;
  int tool_client = -1;     // whose pose the tip follows
  int grasper_client = -1;  // whose pose the grasper follows (its jaws closed)
  const std::string grasper_open = a.grasper_device + "Open";
  int64_t poses = 0;
  std::set<std::pair<int, std::string>> noted;  // (client, type) already logged as skipped

  // The web edge (--web): its own server beside OpenIGTLink's, on this thread, sharing the
  // tool tip and the grasper.
  std::unique_ptr<web::Session> web_session;
  if (web_server) {
    web::SessionOptions so_web;
    so_web.frame_hz = a.web_hz;
    so_web.gain_n_per_mm = a.gain_n_per_mm;
    so_web.hello_fields = {{"max_force_mn", 1000.0 * a.max_force_n},
                           {"tip_radius_mm", a.tip_radius_mm},
                           {"grasp_radius_mm", so_web.grasp_radius_mm},
                           {"frame_hz", a.web_hz}};
    web_session = std::make_unique<web::Session>(std::move(web_server), so_web, loop,
                                                 web::SharedTools{tip, tool_client, grasper_client},
                                                 ready.model);
  }
  const auto open_grasper = [&](const std::string& why) {
    if (grasper_client < 0) return;
    grasper_client = -1;
    loop.set_grasper(std::nullopt);
    log::info("the grasper opens: {}", why);
  };
  const auto start = Clock::now();
  // LaminaRealTime: the rate stepped at, who chose it and whether the machine keeps it. To one
  // client (its answer to LaminaRate), or (-1) as news: to every client while the server
  // streams, and with --send-hz 0 (nothing pushed: a client reads the answer to its request
  // next) only to the client whose rate it is.
  const auto send_rate = [&](int client, const interact::LoopSnapshot& now) {
    const net::Packed status = net::pack_string("LaminaRealTime", rate.status(now));
    if (client >= 0)
      server.send(client, status);
    else if (a.send_hz > 0.0)
      server.broadcast(status);
    else if (rate.client() >= 0)
      server.send(rate.client(), status);
  };
  const auto tell_rate = [&](int client) {
    interact::LoopSnapshot now;
    loop.latest(now);
    send_rate(client, now);
  };
  const auto handle = [&](const net::Message& msg) {
    const std::string& type = msg.header.type;
    const std::string& device = msg.header.device;
    const bool scalpel = !a.scalpel_device.empty();
    if (scalpel && device == a.scalpel_device + "Up") {
      if (stroke.client >= 0) log::info("{}", stroke.finish(loop, a.scalpel_depth_mm));
    } else if (scalpel && device == a.scalpel_device + "Undo") {
      log::info("OpenIGTLink client {}: {} '{}' takes the last cut back", msg.peer, type, device);
      loop.undo_cut();
    } else if (scalpel && device == a.scalpel_device &&
               (type == "TRANSFORM" || type == "POSITION")) {
      const net::Pose pose = net::read_pose(type, msg.content, msg.size);
      if (stroke.client >= 0 && stroke.client != msg.client)
        log::info("{}", stroke.finish(loop, a.scalpel_depth_mm));  // another hand's stroke
      if (stroke.client < 0)
        log::info("OpenIGTLink client {}: {} '{}' begins a scalpel stroke", msg.peer, type, device);
      stroke.add(msg.client, net::change_frame(pose.position, frame),
                 net::change_frame(pose.z_axis, frame), seconds(Clock::now() - start));
    } else if (!a.grasper_device.empty() && msg.header.device == grasper_open) {
      open_grasper(fmt::format("client {} sent {} '{}'", msg.peer, type, grasper_open));
    } else if (!a.grasper_device.empty() && msg.header.device == a.grasper_device &&
               (type == "TRANSFORM" || type == "POSITION")) {
      const interact::Jaws jaws{
          .center_mm = net::change_frame(net::read_position(type, msg.content, msg.size), frame),
          .radius_mm = a.grasper_radius_mm};
      try {
        loop.set_grasper(jaws);
      } catch (const Error& e) {  // nothing under the jaws: said, and nothing held
        if (noted.insert({msg.client, "grasp-miss"}).second)
          log::warn("OpenIGTLink client {}: {} (further misses are not logged)", msg.peer,
                    e.what());
        return;
      }
      if (grasper_client != msg.client)
        log::info("OpenIGTLink client {}: {} '{}' closes the grasper's jaws", msg.peer, type,
                  msg.header.device);
      grasper_client = msg.client;
    } else if (type == "TRANSFORM" || type == "POSITION") {
      const Eigen::Vector3d p = net::read_position(type, msg.content, msg.size);
      if (!a.tool_device.empty() && msg.header.device != a.tool_device) {
        if (noted.insert({msg.client, type + msg.header.device}).second)
          log::info("OpenIGTLink client {}: {} '{}' is not the tool (--tool-device {}); skipped",
                    msg.peer, type, msg.header.device, a.tool_device);
        return;
      }
      ++poses;
      if (tool_client != msg.client)
        log::info("OpenIGTLink client {}: {} '{}' drives the tool tip", msg.peer, type,
                  msg.header.device);
      tool_client = msg.client;
      tip.center_mm = net::change_frame(p, frame);
      tip.active = true;
      loop.set_tool_tip(tip);
    } else if (type == "STRING" && device == "LaminaRate") {
      const std::string text = net::read_string(msg.content, msg.size);
      const std::optional<double> hz = rate.ask(msg.client, msg.peer, text);
      if (hz) loop.set_rate(*hz);
      // A new rate to every client while streaming (this one included), else the answer to it.
      tell_rate(hz && a.send_hz > 0.0 ? -1 : msg.client);
    } else if (type == "GET_POLYDATA") {
      interact::LoopSnapshot snap;
      loop.latest(snap);
      server.send(msg.client, sent_for(snap).requested(snap, msg.header.device));
    } else if (type == "GET_TRANS") {
      interact::LoopSnapshot snap;
      loop.latest(snap);
      server.send(msg.client, outgoing->reaction(snap.reaction_mn));
    } else if (noted.insert({msg.client, type}).second) {
      // The protocol: a receiver skips the types it does not use.
      log::info(
          "OpenIGTLink client {}: skipped {} '{}' (a type lamina serve does not use; "
          "further ones are skipped silently)",
          msg.peer, type, msg.header.device);
    }
  };
  const auto closed = [&](int client) {
    std::erase_if(noted, [&](const auto& n) { return n.first == client; });
    if (const auto hz = rate.gone(client)) {
      loop.set_rate(*hz);
      tell_rate(-1);
    }
    if (client == grasper_client) open_grasper("its client has gone");
    if (client == stroke.client) log::info("{}", stroke.finish(loop, a.scalpel_depth_mm));
    if (client != tool_client) return;
    tool_client = -1;
    tip.active = false;
    loop.set_tool_tip(tip);
    log::info("the tool tip is released: its client has gone");
  };

  struct sigaction action {};
  action.sa_handler = request_stop;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);

  log::info(
      "lamina serve: {} ({} nodes, skin {} nodes and {} triangles, {} layers), {} "
      "in real time; OpenIGTLink on {}:{}{}",
      ready.source, m.node_count(), m.layers[0].node_count, m.layers[0].F.rows(), m.layer_count(),
      a.auto_rate ? fmt::format("{:g} steps/s, then the rate this machine keeps", rate.rate_hz())
                  : fmt::format("{:g} steps/s", rate.rate_hz()),
      a.host, server.port(), a.duration_s > 0.0 ? fmt::format(" for {:g} s", a.duration_s) : "");

  // Sends at send_hz; with --send-hz 0 the snapshot is still watched (real time, reaction).
  const double tick_s = 1.0 / (a.send_hz > 0.0 ? a.send_hz : 30.0);
  const auto tick =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(tick_s));
  const auto deadline = start + std::chrono::duration_cast<Clock::duration>(
                                    std::chrono::duration<double>(a.duration_s));
  // The reaction force streams on its own, every step by default (a haptic client's rate),
  // from the loop's per-step sample: no positions are copied for it.
  const auto reaction_tick = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(1.0 / std::max(a.reaction_hz, 1e-3)));
  auto next_reaction = start;
  const auto embedded_tick = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(1.0 / std::max(a.embedded_hz, 1e-3)));
  auto next_embedded = start;
  std::vector<net::Packed> embedded_batch;
  int64_t reaction_sent_step = -1;
  auto next_tick = start;
  auto next_behind_warning = start;
  bool behind = false;
  double max_reaction_mn = 0.0, behind_s = 0.0;
  interact::LoopSnapshot snap;
  uint64_t last_window = 0;
  int64_t unstable_events = 0;
  bool awaiting_reset = false;
  auto next_unstable_log = start;
  // Each cut (or undo) the loop has made since the last look: in the log, and to every client
  // as a STRING named LaminaCut (what it divided, the pieces, each vessel it crossed: a
  // simulator's bleeding cue). A cut refused is the loop's to log.
  uint64_t cuts_version = 0;
  int64_t cuts_seen = 0;
  const auto report_cuts = [&](const interact::LoopSnapshot& sn) {
    if (sn.model_version == cuts_version) return;
    cuts_version = sn.model_version;
    if (sn.cuts <= cuts_seen) {
      log::info("a cut is undone ({} in force)", sn.cuts);
    } else {
      // (The loop has logged each vessel crossed.)
      log::info(
          "cut {}: {} tetrahedra divided, {} piece(s), {} structure(s) crossed; sent as "
          "STRING 'LaminaCut'",
          sn.cuts, sn.last_cut.cut_tets, sn.last_cut.pieces.size(),
          sn.last_cut.structures_cut.size());
      server.broadcast(net::pack_string("LaminaCut", cut_event_text(sn, frame)));
    }
    cuts_seen = sn.cuts;
  };
  loop.start();
  while (!stop_requested) {
    const auto now = Clock::now();
    if (a.duration_s > 0.0 && now >= deadline) break;
    double wait_s = std::min(seconds(next_tick - now), 0.1);
    if (a.reaction_hz > 0.0) wait_s = std::min(wait_s, seconds(next_reaction - now));
    if (a.embedded_hz > 0.0 && outgoing->embedded_count() > 0)
      wait_s = std::min(wait_s, seconds(next_embedded - now));
    const double now_s = seconds(now - start);
    if (stroke.client >= 0 && now_s - stroke.last_pose_s >= a.scalpel_pause_s)
      log::info("{} (its poses paused)", stroke.finish(loop, a.scalpel_depth_mm));
    if (stroke.client >= 0)
      wait_s = std::min(wait_s, stroke.last_pose_s + a.scalpel_pause_s - now_s);
    if (a.duration_s > 0.0) wait_s = std::min(wait_s, seconds(deadline - now));
    if (web_session) wait_s = std::min(wait_s, web_session->poll());
    server.poll(std::max(wait_s, 0.0), handle, closed);
    if (a.reaction_hz > 0.0 && Clock::now() >= next_reaction) {
      next_reaction += reaction_tick;
      if (next_reaction < Clock::now()) next_reaction = Clock::now() + reaction_tick;
      const interact::ReactionSample r = loop.latest_reaction();
      max_reaction_mn = std::max(max_reaction_mn, r.reaction_mn.norm());
      if (r.steps != reaction_sent_step && server.client_count() > 0) {
        server.stream({outgoing->reaction(r.reaction_mn)}, net::Stream::kSurfaces);
        reaction_sent_step = r.steps;
      }
    }
    // The embedded surfaces are heavier (tens of thousands of triangles): their own rate and
    // their own stream, so that a client still taking one never misses a skin or a reaction.
    if (a.embedded_hz > 0.0 && outgoing->embedded_count() > 0 && Clock::now() >= next_embedded) {
      next_embedded += embedded_tick;
      if (next_embedded < Clock::now()) next_embedded = Clock::now() + embedded_tick;
      if (server.client_count() > 0) {
        loop.latest(snap);
        Outgoing& out = sent_for(snap);
        embedded_batch.clear();
        for (int32_t e = 0; e < out.embedded_count(); ++e)
          embedded_batch.push_back(out.embedded(snap, e));
        server.stream(embedded_batch, net::Stream::kEmbedded);
      }
    }
    if (Clock::now() < next_tick) continue;
    next_tick += tick;
    if (next_tick < Clock::now()) next_tick = Clock::now() + tick;  // no burst after a stall
    loop.latest(snap);
    max_reaction_mn = std::max(max_reaction_mn, snap.reaction_mn.norm());
    report_cuts(snap);
    // Unstable: the loop has stopped and sends no reaction; said in the log, the organ put back
    // at rest so that the session goes on, and the exit code says it happened.
    if (snap.stats.unstable != sim::Instability::kNone && !awaiting_reset) {
      ++unstable_events;
      awaiting_reset = true;
      // A tool held where it blew the organ up blows it up again after each reset: said once,
      // then at most every 10 s with the count.
      if (Clock::now() >= next_unstable_log) {
        log::error(
            "the simulation became unstable at t = {:.3f} s: {}; the organ is reset "
            "to rest (a lower --tip-stiffness, a lower --rate or a stiffer material "
            "avoids it){}",
            snap.time_s, sim::describe(snap.stats.unstable),
            unstable_events > 1 ? fmt::format(" ({} times so far)", unstable_events) : "");
        next_unstable_log = Clock::now() + std::chrono::seconds(10);
      }
      loop.reset();
    } else if (snap.stats.unstable == sim::Instability::kNone) {
      awaiting_reset = false;
    }
    if (a.send_hz > 0.0 && server.client_count() > 0) {
      std::vector<net::Packed> batch;
      Outgoing& out = sent_for(snap);
      for (int32_t k = 0; k < streamed_layers; ++k) batch.push_back(out.layer(snap, k));
      if (a.reaction_hz == 0.0) batch.push_back(out.reaction(snap.reaction_mn));
      server.stream(batch, net::Stream::kSurfaces);
    }
    // The loop measures real time over one-second windows; each new window is judged once.
    const uint64_t window =
        static_cast<uint64_t>(snap.steps > 0 ? seconds(Clock::now() - start) : 0);
    if (window == last_window) continue;
    last_window = window;
    // Every client hears of a new rate, and each second the machine cannot keep the one a
    // client (a haptic device's 1 kHz) or --rate asked for, and when it keeps it again.
    const double asked_hz = rate.rate_hz();  // what the second just measured was asked to keep
    const std::optional<double> new_rate = rate.follow(snap);
    if (new_rate) loop.set_rate(*new_rate);
    if (new_rate || (snap.measured_rate_hz == rate.rate_hz() && (!snap.keeping_up || behind)))
      send_rate(-1, snap);
    // A second measured at another rate than the one asked for says nothing of it.
    if (snap.measured_rate_hz != asked_hz) continue;
    if (!snap.keeping_up) {
      behind_s += 1.0;
      // (The machine's rate moving down has said so itself.)
      if (!new_rate && (!behind || Clock::now() >= next_behind_warning)) {
        log::warn(
            "behind real time: {:.2f} simulated seconds per wall second ({:.0f} of {:.0f} "
            "steps/s, {:.0f} us a step); a lower --rate, a smaller model or, on a busy machine, "
            "--threads 1 keeps up",
            snap.real_time_factor, snap.achieved_rate_hz, rate.rate_hz(), snap.mean_step_us);
        next_behind_warning = Clock::now() + std::chrono::seconds(10);
      }
    } else if (behind) {
      log::info("back in real time ({:.2f} simulated seconds per wall second)",
                snap.real_time_factor);
    }
    behind = !snap.keeping_up;
  }
  loop.stop();
  const double wall_s = seconds(Clock::now() - start);
  loop.latest(snap);
  const double rtf = wall_s > 0.0 ? snap.time_s / wall_s : 0.0;
  if (rtf < 0.95)
    log::warn(
        "the simulation ran at {:.2f}x real time over the whole run; a lower --rate, a smaller "
        "model or, on a busy machine, --threads 1 keeps up",
        rtf);
  outgoing->log_embedded(true);
  if (web_session) web_session->log_summary();
  const net::ServerCounters& c = server.counters();
  fmt::print(stderr,
             "lamina serve: {} steps, {:.2f} s simulated in {:.2f} s ({:.2f}x real time, {:.0f} s "
             "behind, last at {:g} steps/s chosen by the {}); {} clients, {} messages in ({} "
             "poses), {} out ({:.1f} MB, {} frames "
             "skipped), {} connections dropped; max reaction {:.3g} mN; steps waited for the "
             "server {} times, at most {:.3f} ms\n",
             snap.steps, snap.time_s, wall_s, rtf, behind_s, rate.rate_hz(), rate.chosen_by(),
             c.clients, c.messages_in, poses, c.messages_out,
             static_cast<double>(c.bytes_out) / (1 << 20), c.frames_skipped, c.dropped,
             max_reaction_mn, snap.lock_waits, 1e-3 * snap.longest_lock_wait_us);
  if (unstable_events > 0) {
    log::error("the simulation became unstable {} time(s) during the session (see above)",
               unstable_events);
    return static_cast<int>(ErrorKind::kUnstable);
  }
  return 0;
}

}  // namespace lamina::cli
