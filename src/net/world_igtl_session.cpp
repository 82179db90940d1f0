// A world over OpenIGTLink (world_igtl_session.h).
#include "world_igtl_session.h"

#include <fmt/format.h>

#include <algorithm>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "scalpel_stroke.h"
#include "serve_outgoing.h"

namespace lamina::net {

WorldIgtlSession::WorldIgtlSession(const ServeOptions& options, igtlink::Server& server,
                                   world::WorldLoop& loop, ServeRate& rate, Clock::time_point start)
    : a_(options),
      server_(server),
      loop_(loop),
      rate_(rate),
      frame_(options.frame == "lps" ? igtlink::Frame::kLps : igtlink::Frame::kRas),
      hands_(options, loop, frame_, start) {
  loop_.latest(snap_);
  // Each body's skin goes out under the body's name, which the wire carries when it has 1 to 20
  // characters and no other message has it; else as LaminaBodyK (said once).
  std::set<std::string>& taken = taken_;
  taken = {Outgoing::kReactionDevice, "LaminaCut", "LaminaRealTime"};
  for (size_t b = 0; b < snap_.bodies.size(); ++b) {
    const std::string& name = snap_.bodies[b].name;
    std::string device = name;
    if (name.empty() || name.size() > kMaxDeviceName || taken.count(name)) {
      device = fmt::format("LaminaBody{}", b);
      log::info(
          "OpenIGTLink: body '{}' is sent as '{}' (a device name has 1 to {} characters, "
          "unique)",
          name, device, kMaxDeviceName);
    }
    taken.insert(device);
    bodies_.push_back({.device = device, .topology = ~0u, .out = nullptr});
    log::info("OpenIGTLink: POLYDATA '{}': the skin of {}, {} points, {} triangles", device, name,
              snap_.bodies[b].model->layers[0].node_count,
              snap_.bodies[b].model->layers[0].F.rows());
  }
  for (size_t b = 0; b < bodies_.size(); ++b) laid_out(b);
}

// A body's packers, laid out again for the model a cut (or an undo, a reset) gave it: its skin's
// triangles change, and a cut adds the wound to its embedded surfaces.
Outgoing& WorldIgtlSession::laid_out(size_t b) {
  const world::BodyView& v = snap_.bodies[b];
  BodyOut& body = bodies_[b];
  if (body.out && body.topology == v.topology) return *body.out;
  body.out = std::make_unique<Outgoing>(v.model, frame_,
                                        OutgoingNames{.skin = body.device,
                                                      .inner_layers = false,
                                                      .prefix = body.device + "_",
                                                      .taken = taken_});
  body.topology = v.topology;
  return *body.out;
}

igtlink::Packed WorldIgtlSession::skin(size_t b) {
  return laid_out(b).layer(snap_.bodies[b].x, 0);
}

bool WorldIgtlSession::has_embedded() const {
  return std::any_of(bodies_.begin(), bodies_.end(),
                     [](const BodyOut& o) { return o.out && o.out->embedded_count() > 0; });
}

// Their own stream, so that a client still taking one never misses a skin or a reaction.
void WorldIgtlSession::stream_embedded() {
  if (server_.client_count() == 0) return;
  loop_.latest(snap_);
  embedded_batch_.clear();
  for (size_t b = 0; b < snap_.bodies.size() && b < bodies_.size(); ++b) {
    Outgoing& out = laid_out(b);
    for (int32_t e = 0; e < out.embedded_count(); ++e)
      embedded_batch_.push_back(out.embedded(snap_.bodies[b].x, e));
  }
  server_.stream(embedded_batch_, igtlink::Stream::kEmbedded);
}

void WorldIgtlSession::log_embedded(bool at_exit) const {
  for (const BodyOut& o : bodies_)
    if (o.out) o.out->log_embedded(at_exit);
}

std::vector<igtlink::Packed> WorldIgtlSession::skins() {
  std::vector<igtlink::Packed> batch;
  for (size_t b = 0; b < snap_.bodies.size() && b < bodies_.size(); ++b) batch.push_back(skin(b));
  return batch;
}

void WorldIgtlSession::handle(const igtlink::Message& msg) {
  const std::string& type = msg.header.type;
  if (hands_.scalpel_message(msg) || hands_.grasper_message(msg)) return;
  if (type == "TRANSFORM" || type == "POSITION") {
    hands_.tool_pose(msg);
  } else if (type == "STRING" && msg.header.device == "LaminaRate") {
    const std::string text = igtlink::read_string(msg.content, msg.size);
    const std::optional<double> hz = rate_.ask(msg.client, msg.peer, text);
    if (hz) loop_.set_rate(*hz);
    // A new rate to every client while streaming (this one included), else the answer to it.
    tell_rate(hz && a_.send_hz > 0.0 ? -1 : msg.client);
  } else if (type == "GET_POLYDATA") {
    // A body's skin or one of its embedded surfaces by name; any other name: every skin.
    loop_.latest(snap_);
    for (size_t b = 0; b < snap_.bodies.size() && b < bodies_.size(); ++b) {
      Outgoing& out = laid_out(b);
      const int32_t e = out.find_embedded(msg.header.device);
      if (e >= 0) return server_.send(msg.client, out.embedded(snap_.bodies[b].x, e));
      if (msg.header.device == out.skin_device()) return server_.send(msg.client, skin(b));
    }
    for (const igtlink::Packed& p : skins()) server_.send(msg.client, p);
  } else if (type == "GET_TRANS") {
    server_.send(msg.client, reaction_message(loop_.latest_reaction().reaction_mn, frame_));
  } else {
    hands_.skip(msg);
  }
}

void WorldIgtlSession::closed(int client) {
  if (const auto hz = rate_.gone(client)) {
    loop_.set_rate(*hz);
    tell_rate(-1);
  }
  hands_.closed(client);
}

void WorldIgtlSession::tell_rate(int client) {
  world::WorldSnapshot now;
  loop_.latest(now);
  send_rate_status(server_, rate_, client, a_.send_hz > 0.0, now.rate);
}

double WorldIgtlSession::finish_paused_stroke(double now_s) {
  return hands_.finish_paused_stroke(now_s);
}

// From the loop's per-step sample (as the one-organ session's): every step's reaction, where the
// snapshots come at most every publish interval, and no positions copied for it.
void WorldIgtlSession::stream_reaction() {
  const interact::ReactionSample r = loop_.latest_reaction();
  max_reaction_mn_ = std::max(max_reaction_mn_, r.reaction_mn.norm());
  if (r.steps != reaction_sent_step_ && server_.client_count() > 0) {
    server_.stream({reaction_message(r.reaction_mn, frame_)}, igtlink::Stream::kSurfaces);
    reaction_sent_step_ = r.steps;
  }
}

// Each stroke that cut tissue, to every client as a STRING named LaminaCut (what it divided of
// each body, the pieces, each vessel it crossed: a simulator's bleeding cue) and in the log; an
// undo or a reset the loop logs itself.
void WorldIgtlSession::report_cuts() {
  if (snap_.cut_events == cut_events_seen_) return;
  cut_events_seen_ = snap_.cut_events;
  const bool more = snap_.cuts > cuts_seen_;
  cuts_seen_ = snap_.cuts;
  if (!more || snap_.last_cut.empty()) return;
  int64_t tets = 0;
  size_t crossed = 0;
  for (const auto& [name, r] : snap_.last_cut) {
    tets += r.cut_tets;
    crossed += r.structures_cut.size();
  }
  log::info(
      "cut: {} body(ies), {} tetrahedra divided, {} structure(s) crossed; sent as STRING "
      "'LaminaCut'",
      snap_.last_cut.size(), tets, crossed);
  server_.broadcast(igtlink::pack_string("LaminaCut", cut_event_text(snap_, frame_)));
}

void WorldIgtlSession::tick() {
  loop_.latest(snap_);
  report_cuts();
  if (a_.send_hz > 0.0 && server_.client_count() > 0)
    server_.stream(skins(), igtlink::Stream::kSurfaces);
}

void WorldIgtlSession::log_summary(double wall_s) const {
  const igtlink::ServerCounters& c = server_.counters();
  log::info(
      "OpenIGTLink: {} clients, {} messages in ({} poses), {} out ({:.1f} MB, {} frames skipped), "
      "{} connections dropped; max reaction {:.3g} mN over {:.1f} s",
      c.clients, c.messages_in, hands_.poses, c.messages_out,
      static_cast<double>(c.bytes_out) / (1 << 20), c.frames_skipped, c.dropped, max_reaction_mn_,
      wall_s);
}

}  // namespace lamina::net
