#pragma once
// The OpenIGTLink side of `lamina serve` (docs/openigtlink.md): what each client's message does
// to the loop (the tool tip, the grasper, the scalpel, the rate), and what the server streams
// and says as the loop steps (the surfaces, the reaction, each cut, a blow-up, real time kept or
// not). The server's thread calls it between polls; the loop steps on its own thread.

#include <chrono>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "igtl_hands.h"
#include "igtl_server.h"
#include "lamina/net/serve.h"
#include "lamina/world/organ_loop.h"
#include "scalpel_stroke.h"
#include "serve_clock.h"
#include "serve_outgoing.h"
#include "serve_rate.h"

namespace lamina::net {

namespace web {
class Session;
}

class IgtlSession {
 public:
  using Clock = ServeClock;

  IgtlSession(const ServeOptions& args, igtlink::Server& server, world::OrganLoop& loop,
              ServeRate& rate, std::shared_ptr<const Model> model, Clock::time_point start);

  /// A client's message; `closed`: a client has gone (what it held is let go).
  void handle(const igtlink::Message& msg);
  void closed(int client);

  /// A scalpel stroke whose poses paused past --scalpel-pause is finished (it cuts); returns
  /// how long the server may wait before the one under way would be (s; large: none).
  double finish_paused_stroke(double now_s);
  /// The reaction after the loop's latest step, to every client (once per step).
  void stream_reaction();
  /// The embedded surfaces, on their own stream (heavier: their own rate).
  void stream_embedded();
  /// Each tick: the latest snapshot's cuts reported, a blow-up said and the organ reset, the
  /// surfaces streamed, and (each new second) the rate followed and real time judged.
  void tick();

  bool has_embedded() const { return outgoing_->embedded_count() > 0; }
  /// The tool tip and whose hands hold the tip and the grasper: the web session shares them.
  interact::ToolTip& tip() { return hands_.tip; }
  int& tool_client() { return hands_.tool_client; }
  int& grasper_client() { return hands_.grasper_client; }

  /// The session's last words (the web session's among them, if any): the summary line, and
  /// the exit code (ErrorKind::kUnstable if the simulation blew up at any time).
  int finish(double wall_s, const web::Session* web);
  void log_embedded(bool at_exit) const { outgoing_->log_embedded(at_exit); }

 private:
  Outgoing& sent_for(const world::LoopSnapshot& snap);
  void send_rate(int client, const world::LoopSnapshot& now);
  void tell_rate(int client);
  void report_cuts(const world::LoopSnapshot& snap);
  void watch_stability();
  void judge_second();

  const ServeOptions& a_;
  igtlink::Server& server_;
  world::OrganLoop& loop_;
  ServeRate& rate_;
  const igtlink::Frame frame_;
  const Clock::time_point start_;
  // What is sent is laid out for a model; a cut makes another (and adds the wound), which the
  // snapshots then carry: each message is packed for the model of the snapshot it shows.
  std::unique_ptr<Outgoing> outgoing_;
  uint64_t outgoing_version_ = 0;
  const int32_t streamed_layers_;
  IgtlHands<world::OrganLoop> hands_;  // the tool, the grasper, the scalpel's strokes
  world::LoopSnapshot snap_;
  std::vector<igtlink::Packed> embedded_batch_;
  int64_t reaction_sent_step_ = -1;
  double max_reaction_mn_ = 0.0;
  // Each cut (or undo) the loop has made since the last look.
  uint64_t cuts_version_ = 0;
  int64_t cuts_seen_ = 0;
  // Blow-ups: counted, said once and then at most every 10 s.
  int64_t unstable_events_ = 0;
  bool awaiting_reset_ = false;
  Clock::time_point next_unstable_log_;
};

}  // namespace lamina::net
