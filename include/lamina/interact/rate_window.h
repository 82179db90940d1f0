#pragma once
/// \file
/// A real-time loop's measure of itself over its last whole second of wall time: the rate it
/// achieved, its mean step, its worst lateness and how many simulated seconds it made per wall
/// second. The world's loop (world/world_loop.h) keeps one; the one-organ loop is a world of one
/// body.

#include <algorithm>
#include <cstdint>

namespace lamina::interact {

struct RateWindow {
  // What the last whole second measured.
  double achieved_rate_hz = 0.0;  ///< steps per wall second
  double measured_rate_hz = 0.0;  ///< the rate its steps were asked for; 0 before a second
  double real_time_factor = 0.0;  ///< simulated seconds per wall second
  /// Real time was asked for and the simulated clock kept 95% of the wall clock or better.
  bool keeping_up = true;
  double mean_step_us = 0.0;
  double worst_jitter_us = 0.0;  ///< worst lateness of a step's start

  /// Starts the window again at wall time `now_s`, the simulated clock at `sim_s`: a new rate is
  /// judged on its own steps (a window holding the old rate's steps said "behind" of a rate that
  /// had just been lowered).
  void restart(double now_s, double sim_s) {
    start_s_ = now_s;
    sim_start_s_ = sim_s;
    step_sum_us_ = 0.0;
    steps_ = 0;
    jitter_us_ = 0.0;
  }
  /// The simulated clock starts again from `sim_s` (a reset), the wall window going on.
  void restart_sim(double sim_s) { sim_start_s_ = sim_s; }

  /// One step of `step_us` that started `late_us` late and ended at wall time `now_s`, the
  /// simulated clock then at `sim_s`, asked for at `rate_hz` (0: as fast as possible);
  /// `real_time`: the loop follows the wall clock. Closes the second once it is over.
  void add(double step_us, double late_us, double now_s, double sim_s, double rate_hz,
           bool real_time) {
    step_sum_us_ += step_us;
    ++steps_;
    jitter_us_ = std::max(jitter_us_, late_us);
    const double span = now_s - start_s_;
    if (span < 1.0) return;
    achieved_rate_hz = static_cast<double>(steps_) / span;
    measured_rate_hz = rate_hz;
    real_time_factor = (sim_s - sim_start_s_) / span;
    keeping_up = !(real_time && rate_hz > 0.0) || real_time_factor >= 0.95;
    mean_step_us = step_sum_us_ / static_cast<double>(steps_);
    worst_jitter_us = jitter_us_;
    restart(now_s, sim_s);
  }

 private:
  double start_s_ = 0.0, sim_start_s_ = 0.0, step_sum_us_ = 0.0, jitter_us_ = 0.0;
  int64_t steps_ = 0;
};

}  // namespace lamina::interact
