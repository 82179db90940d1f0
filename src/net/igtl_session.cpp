// The OpenIGTLink side of `lamina serve` (igtl_session.h).
#include "igtl_session.h"

#include <fmt/format.h>

#include <algorithm>
#include <limits>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/interact/rate_choice.h"
#include "lamina/sim/simulation.h"
#include "web_session.h"

namespace lamina::net {

IgtlSession::IgtlSession(const ServeOptions& args, igtlink::Server& server, world::OrganLoop& loop,
                         ServeRate& rate, std::shared_ptr<const Model> model,
                         Clock::time_point start)
    : a_(args),
      server_(server),
      loop_(loop),
      rate_(rate),
      frame_(args.frame == "lps" ? igtlink::Frame::kLps : igtlink::Frame::kRas),
      start_(start),
      outgoing_(std::make_unique<Outgoing>(model, frame_)),
      streamed_layers_(args.all_layers ? model->layer_count() : 1),
      hands_(args, loop, frame_, start),
      next_unstable_log_(start) {}

Outgoing& IgtlSession::sent_for(const world::LoopSnapshot& snap) {
  if (snap.model && snap.model_version != outgoing_version_) {
    outgoing_ = std::make_unique<Outgoing>(snap.model, frame_);
    outgoing_version_ = snap.model_version;
  }
  return *outgoing_;
}

// LaminaRealTime: the rate stepped at, who chose it and whether the machine keeps it. To one
// client (its answer to LaminaRate), or (-1) as news: to every client while the server streams,
// and with --send-hz 0 (nothing pushed: a client reads the answer to its request next) only to
// the client whose rate it is.
void IgtlSession::send_rate(int client, const world::LoopSnapshot& now) {
  send_rate_status(server_, rate_, client, a_.send_hz > 0.0, world::measured_window(now));
}

void IgtlSession::tell_rate(int client) {
  world::LoopSnapshot now;
  loop_.latest(now);
  send_rate(client, now);
}

void IgtlSession::handle(const igtlink::Message& msg) {
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
    world::LoopSnapshot snap;
    loop_.latest(snap);
    server_.send(msg.client, sent_for(snap).requested(snap.x, msg.header.device));
  } else if (type == "GET_TRANS") {
    world::LoopSnapshot snap;
    loop_.latest(snap);
    server_.send(msg.client, outgoing_->reaction(snap.reaction_mn));
  } else {
    hands_.skip(msg);
  }
}

void IgtlSession::closed(int client) {
  if (const auto hz = rate_.gone(client)) {
    loop_.set_rate(*hz);
    tell_rate(-1);
  }
  hands_.closed(client);
}

double IgtlSession::finish_paused_stroke(double now_s) {
  return hands_.finish_paused_stroke(now_s);
}

// From the loop's per-step sample: no positions are copied for it.
void IgtlSession::stream_reaction() {
  const interact::ReactionSample r = loop_.latest_reaction();
  max_reaction_mn_ = std::max(max_reaction_mn_, r.reaction_mn.norm());
  if (r.steps != reaction_sent_step_ && server_.client_count() > 0) {
    server_.stream({outgoing_->reaction(r.reaction_mn)}, igtlink::Stream::kSurfaces);
    reaction_sent_step_ = r.steps;
  }
}

// Their own stream, so that a client still taking one never misses a skin or a reaction.
void IgtlSession::stream_embedded() {
  if (server_.client_count() == 0) return;
  loop_.latest(snap_);
  Outgoing& out = sent_for(snap_);
  embedded_batch_.clear();
  for (int32_t e = 0; e < out.embedded_count(); ++e)
    embedded_batch_.push_back(out.embedded(snap_.x, e));
  server_.stream(embedded_batch_, igtlink::Stream::kEmbedded);
}

// Each cut (or undo) in the log, and to every client as a STRING named LaminaCut (what it
// divided, the pieces, each vessel it crossed: a simulator's bleeding cue). A cut refused is the
// loop's to log.
void IgtlSession::report_cuts(const world::LoopSnapshot& sn) {
  if (sn.model_version == cuts_version_) return;
  cuts_version_ = sn.model_version;
  if (sn.cuts <= cuts_seen_) {
    log::info("a cut is undone ({} in force)", sn.cuts);
  } else {
    // (The loop has logged each vessel crossed.)
    log::info(
        "cut {}: {} tetrahedra divided, {} piece(s), {} structure(s) crossed; sent as "
        "STRING 'LaminaCut'",
        sn.cuts, sn.last_cut.cut_tets, sn.last_cut.pieces.size(),
        sn.last_cut.structures_cut.size());
    server_.broadcast(igtlink::pack_string("LaminaCut", cut_event_text(sn, frame_)));
  }
  cuts_seen_ = sn.cuts;
}

// Unstable: the loop has stopped and sends no reaction; said in the log, the organ put back at
// rest so that the session goes on, and the exit code says it happened.
void IgtlSession::watch_stability() {
  if (snap_.stats.unstable == sim::Instability::kNone) {
    awaiting_reset_ = false;
    return;
  }
  if (awaiting_reset_) return;
  ++unstable_events_;
  awaiting_reset_ = true;
  // A tool held where it blew the organ up blows it up again after each reset: said once, then
  // at most every 10 s with the count.
  if (Clock::now() >= next_unstable_log_) {
    log::error(
        "the simulation became unstable at t = {:.3f} s: {}; the organ is reset "
        "to rest (a lower --tip-stiffness, a lower --rate or a stiffer material "
        "avoids it){}",
        snap_.time_s, sim::describe(snap_.stats.unstable),
        unstable_events_ > 1 ? fmt::format(" ({} times so far)", unstable_events_) : "");
    next_unstable_log_ = Clock::now() + std::chrono::seconds(10);
  }
  loop_.reset();
}

// The loop measures real time over one-second windows; each new window is judged once
// (ServeRate::judge). Every client hears of a new rate, and each second the machine cannot keep
// the one a client (a haptic device's 1 kHz) or --rate asked for, and when it keeps it again.
void IgtlSession::judge_second() {
  const uint64_t second =
      static_cast<uint64_t>(snap_.steps > 0 ? seconds(Clock::now() - start_) : 0);
  const ServeRate::Judgement j = rate_.judge(world::measured_window(snap_), second);
  if (j.new_rate) loop_.set_rate(*j.new_rate);
  if (j.tell) send_rate(-1, snap_);
}

void IgtlSession::tick() {
  loop_.latest(snap_);
  max_reaction_mn_ = std::max(max_reaction_mn_, snap_.reaction_mn.norm());
  report_cuts(snap_);
  watch_stability();
  if (a_.send_hz > 0.0 && server_.client_count() > 0) {
    std::vector<igtlink::Packed> batch;
    Outgoing& out = sent_for(snap_);
    for (int32_t k = 0; k < streamed_layers_; ++k) batch.push_back(out.layer(snap_.x, k));
    if (a_.reaction_hz == 0.0) batch.push_back(out.reaction(snap_.reaction_mn));
    server_.stream(batch, igtlink::Stream::kSurfaces);
  }
  judge_second();
}

int IgtlSession::finish(double wall_s, const web::Session* web) {
  loop_.latest(snap_);
  const double rtf = wall_s > 0.0 ? snap_.time_s / wall_s : 0.0;
  if (rtf < 0.95)
    log::warn(
        "the simulation ran at {:.2f}x real time over the whole run; a lower --rate, a smaller "
        "model or, on a busy machine, --threads 1 keeps up",
        rtf);
  outgoing_->log_embedded(true);
  if (web != nullptr) web->log_summary();
  const igtlink::ServerCounters& c = server_.counters();
  fmt::print(stderr,
             "lamina serve: {} steps, {:.2f} s simulated in {:.2f} s ({:.2f}x real time, {:.0f} s "
             "behind, last at {:g} steps/s chosen by the {}); {} clients, {} messages in ({} "
             "poses), {} out ({:.1f} MB, {} frames "
             "skipped), {} connections dropped; max reaction {:.3g} mN; steps waited for the "
             "server {} times, at most {:.3f} ms\n",
             snap_.steps, snap_.time_s, wall_s, rtf, rate_.behind_s(), rate_.rate_hz(),
             rate_.chosen_by(), c.clients, c.messages_in, hands_.poses, c.messages_out,
             static_cast<double>(c.bytes_out) / (1 << 20), c.frames_skipped, c.dropped,
             max_reaction_mn_, snap_.lock_waits, 1e-3 * snap_.longest_lock_wait_us);
  if (unstable_events_ > 0) {
    log::error("the simulation became unstable {} time(s) during the session (see above)",
               unstable_events_);
    return static_cast<int>(ErrorKind::kUnstable);
  }
  return 0;
}

}  // namespace lamina::net
