// web::WorldSession (world_web_session.h): a page's messages onto the world's loop, and the
// world's frames back.
#include "world_web_session.h"

#include <fmt/format.h>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/world/pick_body.h"
#include "web_message.h"
#include "world_stream.h"

namespace lamina::net::web {
namespace {

using Clock = std::chrono::steady_clock;
using json = nlohmann::json;

}  // namespace

WorldSession::WorldSession(std::unique_ptr<Server> server, SessionOptions options,
                           world::WorldLoop& loop)
    : server_(std::move(server)), options_(std::move(options)), loop_(loop) {
  loop_.latest(snap_);
  const WorldStreamModel layout = world_stream_model(snap_);
  json fields = options_.hello_fields;
  fields["world"] = true;
  fields["bodies"] = layout.bodies;
  // Carried by the drawn vertices: each body's points are a range of the stream's (the hello's
  // "bodies"), whatever the bodies' inner nodes.
  stream_ = std::make_unique<WebStream>(layout.model, fields, Carry::kVertices, layout.colors);
  server_->on(
      [this](int client, const std::string&) { opened(client); },
      [this](int client, const std::string&, const std::string& text) { handle(client, text); },
      [this](int client) { closed(client); });
  next_frame_ = Clock::now();
  log::info("web: a world of {} bodies, {} surfaces, {} triangles, carried by {} vertices",
            snap_.bodies.size(), stream_->setup().size() - 1, stream_->drawn_triangles(),
            stream_->streamed_points());
}

void WorldSession::opened(int client) {
  server_->send(
      client, std::make_shared<const std::string>(stream_->hello(client + kWebClientBase)), false);
  for (const std::string& m : stream_->setup())
    server_->send(client, std::make_shared<const std::string>(m), true);
}

void WorldSession::event(int client, const std::string& text) {
  server_->send(client,
                std::make_shared<const std::string>(
                    json{{"type", "event"}, {"text", text}, {"bad", false}}.dump()),
                false);
}

void WorldSession::release_drag() {
  if (drag_.client < 0) return;
  try {
    loop_.set_forces(drag_.body, drag_.topology, {});
  } catch (const Error& e) {  // the body's topology changed since: its forces went with it
    log::info("web: {}", e.what());
  }
  drag_ = {};
}

void WorldSession::handle(int client, const std::string& text) {
  const json m = parse_message(text);
  const std::string type = m["type"].get<std::string>();
  if (type == "hand") {
    // Checked as the one-organ session checks it (a malformed hand drops its client), then
    // told, once, that hands act on one organ only.
    number(m, "hand", 0, 1);
    number(m, "pose", 0, 4294967295.0);
    vector3(m, "position", 1e5);
    number(m, "trigger", 0, 1);
    number(m, "grip", 0, 1);
    if (told_hands_.insert(client).second)
      event(client,
            "in a world the hands do nothing yet (the tool tip and the grasper act on one "
            "organ): drag an organ with the mouse");
  } else if (type == "press") {
    const Eigen::Vector3d origin = vector3(m, "origin", 1e6);
    const Eigen::Vector3d direction = vector3(m, "direction", 1e6);
    if (!(direction.norm() > 0.0)) throw invalid_input("message", "'direction' has zero length");
    if (drag_.client == client) release_drag();
    loop_.latest(snap_);
    const world::BodyHit hit = world::pick_body(snap_, origin, direction.normalized());
    if (hit.body < 0 || drag_.client >= 0) return;  // nothing there, or another page drags
    const world::BodyView& b = snap_.bodies[static_cast<size_t>(hit.body)];
    drag_ = {client, b.id, b.topology, hit.skin.node};
    log::info("web client {}: drags {} node {}", client + kWebClientBase, b.name, hit.skin.node);
  } else if (type == "drag") {
    const Eigen::Vector3d drag = vector3(m, "drag_mm", 1e4);
    if (drag_.client != client) return;
    try {
      loop_.set_forces(drag_.body, drag_.topology,
                       {interact::LiveForce{.node = drag_.node,
                                            .force_mn = 1000.0 * options_.gain_n_per_mm * drag}});
    } catch (const Error& e) {  // a stale body or topology: said, the drag ends
      event(client, e.what());
      drag_ = {};
    }
  } else if (type == "release") {
    if (drag_.client == client) release_drag();
  } else {
    throw invalid_input("message", "unknown type '" + type + "'");
  }
}

void WorldSession::closed(int client) {
  if (drag_.client == client) release_drag();
  told_hands_.erase(client);
}

void WorldSession::send_frame() {
  loop_.latest(snap_);
  stack_positions(snap_, stacked_);
  FrameInfo info;
  info.frame = ++frames_;
  info.time_s = snap_.time_s;
  info.steps = snap_.steps;
  info.sent_at_us = static_cast<uint64_t>(
      std::chrono::duration_cast<std::chrono::microseconds>(Clock::now().time_since_epoch())
          .count());
  info.unstable = snap_.unstable != sim::Instability::kNone;
  info.behind = !snap_.rate.keeping_up;
  const auto t0 = Clock::now();
  auto frame = std::make_shared<const std::string>(stream_->frame(stacked_, info));
  const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  if (encode_ms_.size() < 100000) {
    encode_ms_.push_back(ms);
    frame_kb_.push_back(static_cast<double>(frame->size()) / 1e3);
  }
  server_->stream(std::move(frame));
}

double WorldSession::poll() {
  server_->poll();
  if (server_->client_count() == 0) return 0.01;
  const auto now = Clock::now();
  if (now >= next_frame_) {
    next_frame_ += std::chrono::duration_cast<Clock::duration>(
        std::chrono::duration<double>(1.0 / options_.frame_hz));
    if (next_frame_ < now) next_frame_ = now;
    send_frame();
    server_->poll();
  }
  return 0.001;
}

void WorldSession::log_summary() const {
  const ServerCounters& c = server_->counters();
  log::info(
      "web: {} clients, {} messages in, {} frames out ({:.1f} MB, median {:.1f} kB a frame, "
      "encoded in {:.2f} ms median), {} frames skipped for busy clients, {} connections dropped",
      c.clients, c.messages_in, c.frames_out, static_cast<double>(c.bytes_out) / (1 << 20),
      median(frame_kb_), median(encode_ms_), c.frames_skipped, c.dropped);
}

}  // namespace lamina::net::web
