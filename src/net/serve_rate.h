#pragma once
// Which rate `lamina serve` steps at (issue 48: real time by default). Without --rate the rate
// follows the machine as the viewer's does (interact::next_rate: the highest of 1000, 500, 250,
// 120, 60 Hz it keeps, checked each second). A client may ask for one with a STRING named
// LaminaRate ("1000" for a haptic device, "auto" to give it back); the rate it asks is kept while
// it is connected, and every client is told, as a STRING named LaminaRealTime, when the rate
// changes and each second the machine cannot keep it (docs/openigtlink.md). One organ's serve and
// a world's alike: each judged on its loop's one-second window (interact::RateWindow).

#include <optional>
#include <string>

#include "igtl_server.h"
#include "lamina/interact/rate_window.h"
#include "serve_clock.h"

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
  /// From the loop's latest window: a rate the machine keeps when nobody chose one
  /// (interact::rate_to_follow: judged on each second measured at the rate stepped at).
  std::optional<double> follow(const interact::RateWindow& measured);

  /// What LaminaRealTime says (JSON): rate_hz, chosen_by and, once a second has been measured at
  /// that rate, keeping_up, real_time_factor, step_ms and, when behind, keeps_up_hz (the highest
  /// rung whose period holds the step).
  std::string status(const interact::RateWindow& measured) const;

  /// What a second of the serve decided: a rate to step at now, and whether the clients hear
  /// the rate (a new one, or a second behind it, or back in real time).
  struct Judgement {
    std::optional<double> new_rate;
    bool tell = false;
  };
  /// Judges the loop's latest window once per wall second of the serve (`second`, counted from
  /// its start; 0 before its first step): the machine's rate followed (follow()), and each
  /// second behind the rate asked for counted and logged (at most every 10 s; back in real time
  /// once). A second measured at another rate says nothing of the one asked for now.
  Judgement judge(const interact::RateWindow& measured, uint64_t second);
  /// Wall seconds the serve spent behind the rate it was asked to keep.
  double behind_s() const { return behind_s_; }

 private:
  std::optional<double> change_to(double hz);
  double base_hz_;       // --rate, or where the machine's rate stood when a client asked
  bool follow_machine_;  // no --rate
  double rate_hz_;       // stepped at now
  int client_ = -1;      // whose asked rate holds; -1: none
  // Real time, judged on the loop's one-second windows.
  uint64_t last_second_ = 0;
  bool behind_ = false;
  double behind_s_ = 0.0;
  ServeClock::time_point next_behind_warning_{};
};

/// LaminaRealTime (ServeRate::status of `measured`) to `client`, or (-1) as news: to every client
/// while the server streams (`streaming`), else (nothing pushed: a client reads the answer to its
/// request next) only to the client whose rate it is.
void send_rate_status(igtlink::Server& server, const ServeRate& rate, int client, bool streaming,
                      const interact::RateWindow& measured);

}  // namespace lamina::net
