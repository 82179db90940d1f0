// web::WorldSession (world_web_session.h): a page's messages onto the world's loop, and the
// world's frames back.
#include "world_web_session.h"

#include <fmt/format.h>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/world/pick_body.h"
#include "serve_clock.h"
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

// Whether the dragged body's topology is past the drag's in the loop itself (its snapshot may
// not show it yet).
bool WorldSession::topology_moved_on() const {
  for (const auto& [id, topology] : loop_.bodies())
    if (id == drag_.body) return topology != drag_.topology;
  return false;
}

// The dragged body renumbered since the drag's last force (a cut carried the force to its node's
// first copy; a reset or an undo let it go): the drag goes on from the node's copy, or ends.
void WorldSession::follow_cut() {
  if (!drag_.pushing) return;
  loop_.latest(snap_);
  for (const world::BodyView& b : snap_.bodies) {
    if (b.id != drag_.body || b.topology == drag_.topology) continue;
    const auto now = world::carried_force_nodes(
        b, {interact::LiveForce{.node = drag_.node, .force_mn = Eigen::Vector3d::Zero()}});
    if (!now) {  // released, or not the page's force alone: the drag ends, and lets go of it
      try {
        if (!b.force_nodes.empty()) loop_.set_forces(b.id, b.topology, {});
      } catch (const Error& e) {  // renumbered again since: its forces went with it
        log::info("web: {}", e.what());
      }
      drag_ = {};
      return;
    }
    drag_.node = (*now)[0];
    drag_.topology = b.topology;
  }
}

void WorldSession::handle(int client, const std::string& text) {
  const json m = parse_message(text);
  const std::string type = m["type"].get<std::string>();
  if (type == "hand") {
    hand(client, m);
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
    follow_cut();
    if (drag_.client != client) return;  // the cut's body was put back: the drag ended
    try {
      loop_.set_forces(drag_.body, drag_.topology,
                       {interact::LiveForce{.node = drag_.node,
                                            .force_mn = 1000.0 * options_.gain_n_per_mm * drag}});
      drag_.pushing = true;
    } catch (const Error& e) {
      // A cut taken between the snapshot this drag followed and its force: the loop carried the
      // force the drag was pushing with, and the next message follows it there once the
      // snapshot shows the cut. Anything else (a press not yet pushing has no force to carry) is
      // said, and the drag ends.
      if (drag_.pushing && topology_moved_on()) {
        log::debug("web: a drag met a cut not yet published; the next one follows it");
        return;
      }
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
  if (tip_hand_.client == client) release_tip();
  if (grasp_hand_.client == client) release_grasper();
}

// A controller: its tip's position (mm, the world's frame), trigger and grip in [0, 1]. Checked
// as the one-organ session checks it (a malformed hand drops its client); one hand at a time
// holds the tip, one the grasper.
void WorldSession::hand(int client, const json& m) {
  const auto [which, pose, p, trigger, grip] = read_hand(m);
  const bool holds_tip = tip_hand_.client == client && tip_hand_.hand == which;
  if (trigger && (tip_hand_.client < 0 || holds_tip)) {
    if (!holds_tip)
      log::info("web client {}: hand {} drives the tool tip", client + kWebClientBase, which);
    tip_ = options_.tip;
    tip_.active = true;
    tip_.center_mm = p;
    loop_.set_tool_tip(tip_);
    tip_hand_ = {client,      which, pose, loop_.latest_reaction().steps, tip_hand_.reflected,
                 Clock::now()};
  } else if (!trigger && holds_tip) {
    release_tip();
  }
  const bool holds_grasper = grasp_hand_.client == client && grasp_hand_.hand == which;
  if (grip && (grasp_hand_.client < 0 || holds_grasper)) {
    try {
      loop_.set_grasper(interact::Jaws{.center_mm = p, .radius_mm = options_.grasp_radius_mm});
    } catch (const Error& e) {  // nothing under the jaws: said to that page, nothing held
      if (!holds_grasper && !grasp_missed_) event(client, e.what());
      grasp_missed_ = true;
      return;
    }
    grasp_missed_ = false;
    if (!holds_grasper)
      log::info("web client {}: hand {} closes the grasper", client + kWebClientBase, which);
    grasp_hand_ = {client,      which, pose, loop_.latest_reaction().steps, grasp_hand_.reflected,
                   Clock::now()};
  } else if (!grip && holds_grasper) {
    release_grasper();
  } else if (!grip) {
    grasp_missed_ = false;
  }
}

void WorldSession::release_tip() {
  tip_.active = false;
  loop_.set_tool_tip(tip_);
  tip_hand_ = {};
}

void WorldSession::release_grasper() {
  loop_.set_grasper(std::nullopt);
  grasp_hand_ = {};
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
  // The hands: each one's newest pose the snapshot shows, and the tissue's push on them.
  Hand* held[2] = {&tip_hand_, &grasp_hand_};
  for (int k = 0; k < 2; ++k) {
    Hand& h = *held[k];
    ToolInfo& t = info.tools[k];
    if (h.client < 0) continue;
    t.client = h.client + kWebClientBase;
    t.hand = h.hand;
    // The newest pose applied before the snapshot's step (a pose applied after it is not in it).
    if (snap_.steps > h.pose_step && h.reflected != h.pose) {
      h.reflected = h.pose;
      if (pose_to_frame_ms_.size() < 100000)
        pose_to_frame_ms_.push_back(
            std::chrono::duration<double, std::milli>(Clock::now() - h.pose_at).count());
    }
    t.pose = h.reflected;
    t.reaction_mn = snap_.hands_reaction_mn;
    t.contact = k == 0 ? snap_.tip_touching : !snap_.grasped_body.empty();
  }
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
  if (frame_due(next_frame_, every(options_.frame_hz))) {
    send_frame();
    server_->poll();
  }
  return 0.001;
}

void WorldSession::log_summary() const {
  const ServerCounters& c = server_->counters();
  log::info(
      "web: {} clients, {} messages in, {} frames out ({:.1f} MB, median {:.1f} kB a frame, "
      "encoded in {:.2f} ms median), {} frames skipped for busy clients, {} connections dropped; "
      "a pose to the first frame showing it: {:.1f} ms median ({} poses)",
      c.clients, c.messages_in, c.frames_out, static_cast<double>(c.bytes_out) / (1 << 20),
      median(frame_kb_), median(encode_ms_), c.frames_skipped, c.dropped, median(pose_to_frame_ms_),
      pose_to_frame_ms_.size());
}

}  // namespace lamina::net::web
