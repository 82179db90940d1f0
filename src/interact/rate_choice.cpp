// The rate a real-time loop keeps: down the ladder at once when the step does not fit its budget,
// up one rung at a time when it takes little of it.
#include "lamina/interact/rate_choice.h"

#include "lamina/core/log.h"

namespace lamina::interact {

double next_rate(double rate_hz, double mean_step_us, bool keeping_up) {
  if (!(mean_step_us > 0.0) || !(rate_hz > 0.0)) return rate_hz;
  const double period_us = 1e6 / rate_hz;
  if (!keeping_up) {
    // The step grows with dt (more solver iterations), so the rung that fits is checked against
    // the step measured at the faster rate: it may need another rung down a second later.
    for (const double hz : kRateLadder)
      if (hz < rate_hz && mean_step_us <= kRateBudget * 1e6 / hz) return hz;
    return kRateLadder.back();
  }
  if (mean_step_us < kRateHeadroom * period_us)
    for (auto it = kRateLadder.rbegin(); it != kRateLadder.rend(); ++it)
      if (*it > rate_hz) return *it;
  return rate_hz;
}

std::optional<double> rate_to_follow(double rate_hz, const RateWindow& snap,
                                     const char* forced_by) {
  if (snap.measured_rate_hz != rate_hz || !(snap.mean_step_us > 0.0)) return std::nullopt;
  const double next = next_rate(rate_hz, snap.mean_step_us, snap.keeping_up);
  if (next == rate_hz) return std::nullopt;
  log::info(
      "real time: a step took {:.2f} ms at {:.0f} Hz; stepping at {:.0f} Hz now (dt {:.3g} ms; "
      "{} forces a rate)",
      snap.mean_step_us / 1000.0, rate_hz, next, 1000.0 / next, forced_by);
  return next;
}

}  // namespace lamina::interact
