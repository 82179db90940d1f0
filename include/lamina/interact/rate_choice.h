#pragma once
/// \file
/// Which rate a real-time loop can keep on the machine it runs on (issue 48: real time by
/// default). The viewer and `lamina serve` start at 1 kHz unless a rate is forced, measure the
/// step over each second, and move down the ladder (1000, 500, 250, 120, 60 Hz; dt = 1 / rate)
/// when the steps take more than their margin of the budget, and back up when they take little
/// of it.

#include <array>

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

}  // namespace lamina::interact
