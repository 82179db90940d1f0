#pragma once
/// \file
/// Which rate a real-time loop can keep on the machine it runs on (issue 48: real time by
/// default). The viewer and `lamina serve` start at 1 kHz unless a rate is forced, measure the
/// step over each second, and move down the ladder (1000, 500, 250, 120, 60 Hz; dt = 1 / rate)
/// when the steps take more than their margin of the budget, and back up when they take little
/// of it.

#include <array>
#include <optional>

#include "lamina/interact/rate_window.h"

namespace lamina::interact {

/// The rates a loop may choose, highest first.
inline constexpr std::array<double, 5> kRateLadder = {1000.0, 500.0, 250.0, 120.0, 60.0};

/// When the loop falls behind, the rate goes down to the highest rung whose period holds the
/// step with this part of it (the rest is the margin: the tools' routing, publishing, the
/// machine's own stalls). A loop that keeps up stays where it is.
inline constexpr double kRateBudget = 0.8;
/// A step taking less than this part of its period moves the rate one rung up (a longer step
/// costs an implicit solve more iterations, so up is one rung at a time and checked again).
inline constexpr double kRateHeadroom = 0.25;

/// The rate to step at next, from the one stepped at (`rate_hz`, on the ladder), the mean step
/// measured at it (us) and whether the last second kept real time: behind, the highest rung
/// below whose period holds the step within kRateBudget (the lowest rung if none); keeping up,
/// one rung up when the step takes under kRateHeadroom of its period, else the same. A step of
/// 0 (none measured yet) keeps the rate.
double next_rate(double rate_hz, double mean_step_us, bool keeping_up);

/// The rung a loop stepping at `rate_hz` moves to, judged on its last measured second
/// (next_rate()), or nothing: nothing until a second has been measured at `rate_hz`
/// (RateWindow::measured_rate_hz; the loop's window starts again at a new rate, so a rate just
/// set is judged on a whole second of its own steps), nor when next_rate() keeps it. A move is
/// logged, naming `forced_by` (what forces a rate instead). The viewer's and `lamina serve`'s.
std::optional<double> rate_to_follow(double rate_hz, const RateWindow& measured,
                                     const char* forced_by);

}  // namespace lamina::interact
