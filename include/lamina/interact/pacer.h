#pragma once
/// \file
/// The schedule of a loop that steps in real time (a haptic device's 1 kHz): one tick every
/// 1 / rate seconds of wall time. The realtime loop and `lamina run --realtime` share it.

#include <chrono>

namespace lamina::interact {

/// Ticks 1 / rate_hz apart on the steady clock. A step starts at its tick, not as soon as the one
/// before ends, so that the simulated clock follows the wall clock.
class Pacer {
 public:
  using Clock = std::chrono::steady_clock;

  /// @param[in] rate_hz  ticks per second; 0 = no schedule (every tick is now)
  explicit Pacer(double rate_hz = 0.0) { set_rate(rate_hz); }

  /// Changes the rate from the next tick on.
  void set_rate(double rate_hz) {
    period_ = rate_hz > 0.0 ? std::chrono::duration_cast<Clock::duration>(
                                  std::chrono::duration<double>(1.0 / rate_hz))
                            : Clock::duration::zero();
  }

  /// True when ticks are apart (a rate was given): then the caller waits for each.
  bool paced() const { return period_ != Clock::duration::zero(); }

  /// The schedule starts again: the next tick is now (after a pause).
  void restart() { tick_ = Clock::now(); }

  /// How late now is against the current tick, us: the jitter of a step starting now (0 without
  /// a rate, or when early).
  double lateness_us() const {
    if (period_ == Clock::duration::zero()) return 0.0;
    const double late = std::chrono::duration<double, std::micro>(Clock::now() - tick_).count();
    return late > 0.0 ? late : 0.0;
  }

  /// Moves to the next tick and returns it, for the caller to wait until. A loop that fell more
  /// than 50 periods behind (a debugger, a busy machine) starts afresh from now instead of racing
  /// through the steps it missed.
  Clock::time_point advance() {
    const Clock::time_point now = Clock::now();
    if (period_ == Clock::duration::zero()) return tick_ = now;
    tick_ += period_;
    if (now - tick_ > 50 * period_) tick_ = now;
    return tick_;
  }

 private:
  Clock::duration period_{};
  Clock::time_point tick_ = Clock::now();
};

}  // namespace lamina::interact
