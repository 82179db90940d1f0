#pragma once
// The OpenIGTLink side of a world's serve (docs/openigtlink.md, "A world"): each body's skin
// streamed as a POLYDATA named after the body, its embedded surfaces (vessels, a cut's wound)
// after the body and the surface (liver_portal_vein) at --embedded-hz, a tool's pose driving the
// world's tool tip (it pushes whichever body it touches), the grasper's device its grasper (it
// closes on the body nearest its jaws), the scalpel's strokes cutting every body they pass, the
// tissue's push on the hands sent back as LaminaReaction, each cut reported as LaminaCut, and the
// rate: a client's LaminaRate asks for one, and LaminaRealTime says it (net::ServeRate, as for one
// organ). The server's thread calls it between polls; the world steps on its own thread
// (world::WorldLoop).
#include <chrono>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "igtl_hands.h"
#include "igtl_server.h"
#include "lamina/net/serve.h"
#include "lamina/world/world_loop.h"
#include "serve_clock.h"
#include "serve_outgoing.h"
#include "serve_rate.h"

namespace lamina::net {

class WorldIgtlSession {
 public:
  using Clock = ServeClock;

  WorldIgtlSession(const ServeOptions& options, igtlink::Server& server, world::WorldLoop& loop,
                   ServeRate& rate, Clock::time_point start);

  /// A client's message; `closed`: a client has gone (what it held is let go).
  void handle(const igtlink::Message& msg);
  void closed(int client);
  /// A scalpel stroke whose poses paused past scalpel_pause_s cuts; how long the server may
  /// wait before the one under way would (s; large: none).
  double finish_paused_stroke(double now_s);
  /// The push on the hands after the world's latest step, to every client (once per step).
  void stream_reaction();
  /// Each tick: every body's skin to every client (laid out again for a body a cut renumbered).
  void tick();
  /// Every body's embedded surfaces, on their own stream (heavier: their own rate).
  void stream_embedded();
  bool has_embedded() const;
  /// One line per embedded surface sent (at exit: what a frame of it cost).
  void log_embedded(bool at_exit) const;
  /// LaminaRealTime (the rate, who chose it, whether the machine keeps it) to `client`, or (-1)
  /// as news: to every client while the server streams, else to the client whose rate it is.
  void tell_rate(int client);
  /// The session's summary line.
  void log_summary(double wall_s) const;

 private:
  struct BodyOut {
    std::string device;
    uint32_t topology = ~0u;        // the body's topology its packers are laid out for
    std::unique_ptr<Outgoing> out;  // its skin and embedded surfaces, named after it
  };
  Outgoing& laid_out(size_t b);
  igtlink::Packed skin(size_t b);
  std::vector<igtlink::Packed> skins();
  void report_cuts();

  const ServeOptions& a_;
  igtlink::Server& server_;
  world::WorldLoop& loop_;
  ServeRate& rate_;
  const igtlink::Frame frame_;
  IgtlHands<world::WorldLoop> hands_;
  world::WorldSnapshot snap_;
  std::vector<BodyOut> bodies_;  // per snapshot body
  std::set<std::string> taken_;  // the skins' device names and the session's own messages
  std::vector<igtlink::Packed> embedded_batch_;
  int64_t reaction_sent_step_ = -1;
  double max_reaction_mn_ = 0.0;
  uint64_t cut_events_seen_ = 0;  // the snapshot's cut_events last reported
  int32_t cuts_seen_ = 0;
};

}  // namespace lamina::net
