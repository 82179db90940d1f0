#pragma once
// Which rate `lamina serve` steps at (issue 48: real time by default). Without --rate the rate
// follows the machine as the viewer's does (interact::next_rate: the highest of 1000, 500, 250,
// 120, 60 Hz it keeps, checked each second). A client may ask for one with a STRING named
// LaminaRate ("1000" for a haptic device, "auto" to give it back); the rate it asks is kept while
// it is connected, and every client is told, as a STRING named LaminaRealTime, when the rate
// changes and each second the machine cannot keep it (docs/openigtlink.md).

#include <optional>
#include <string>

#include "lamina/interact/realtime_loop.h"

namespace lamina::net {

class ServeRate {
 public:
  /// `follow_machine` false: `rate_hz` is --rate's, kept unless a client asks for another;
  /// true: the machine's rate, from 1 kHz.
  ServeRate(double rate_hz, bool follow_machine);

  double rate_hz() const { return rate_hz_; }
  /// The client whose asked rate holds; -1: none.
  int client() const { return client_; }
  /// Who chose the rate: "client", "--rate" or "machine".
  const char* chosen_by() const;

  /// A LaminaRate STRING from `client` (`peer` for the log): a rate in Hz or "auto". Returns the
  /// rate to step at now, if it changes. Throws lamina::Error (kInvalidInput) for other text.
  std::optional<double> ask(int client, const std::string& peer, const std::string& text);
  /// `client` has gone: a rate it asked for is given back.
  std::optional<double> gone(int client);
  /// From the loop's latest snapshot: a rate the machine keeps when nobody chose one
  /// (interact::rate_to_follow: judged on each second measured at the rate stepped at).
  std::optional<double> follow(const interact::LoopSnapshot& snap);

  /// What LaminaRealTime says (JSON): rate_hz, chosen_by and, once a second has been measured at
  /// that rate, keeping_up, real_time_factor, step_ms and, when behind, keeps_up_hz (the highest
  /// rung whose period holds the step).
  std::string status(const interact::LoopSnapshot& snap) const;

 private:
  std::optional<double> change_to(double hz);
  double base_hz_;       // --rate, or where the machine's rate stood when a client asked
  bool follow_machine_;  // no --rate
  double rate_hz_;       // stepped at now
  int client_ = -1;      // whose asked rate holds; -1: none
};

}  // namespace lamina::net
