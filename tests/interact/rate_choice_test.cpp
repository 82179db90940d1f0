// The rate a real-time loop keeps (issue 48, real time by default): behind, down the ladder at
// once to the rung whose period the measured step fits with its margin; keeping up, one rung up
// only when the step takes little of its period; never off the ladder; nothing changed before a
// step is measured.
#include "lamina/interact/rate_choice.h"

#include <gtest/gtest.h>

namespace lamina::interact {
namespace {

TEST(RateChoice, DownToTheRungTheStepFitsUpOneRungWithHeadroomElseTheSame) {
  // Keeping up with a step well inside the budget: stays.
  EXPECT_EQ(next_rate(1000.0, 500.0, true), 1000.0);
  // 1.2 ms steps at 1 kHz cannot keep up: 500 Hz (2 ms) holds 1.2 ms within 80%.
  EXPECT_EQ(next_rate(1000.0, 1200.0, false), 500.0);
  // 0.9 ms steps that keep up at 1 kHz stay there; behind with them, 500 Hz.
  EXPECT_EQ(next_rate(1000.0, 900.0, true), 1000.0);
  EXPECT_EQ(next_rate(1000.0, 900.0, false), 500.0);
  // 5 ms steps: 120 Hz (8.3 ms) is the first rung with 20% to spare.
  EXPECT_EQ(next_rate(1000.0, 5000.0, false), 120.0);
  // Slower than any rung: the lowest, and the loop says it is behind.
  EXPECT_EQ(next_rate(250.0, 40000.0, false), 60.0);
  // At 250 Hz, 0.9 ms steps are 22% of the period: one rung up, not straight to 1 kHz.
  EXPECT_EQ(next_rate(250.0, 900.0, true), 500.0);
  // At 500 Hz, 0.8 ms steps (40%): the hysteresis keeps 500 (1 kHz would take 80%).
  EXPECT_EQ(next_rate(500.0, 800.0, true), 500.0);
  // The top rung goes no higher; nothing measured yet changes nothing.
  EXPECT_EQ(next_rate(1000.0, 10.0, true), 1000.0);
  EXPECT_EQ(next_rate(500.0, 0.0, false), 500.0);
  // Every answer is on the ladder.
  for (const double rate : kRateLadder)
    for (const double step : {1.0, 100.0, 700.0, 3000.0, 1e5})
      for (const bool keeping : {false, true}) {
        const double next = next_rate(rate, step, keeping);
        bool on = false;
        for (const double hz : kRateLadder) on = on || next == hz;
        EXPECT_TRUE(on) << rate << " " << step << " -> " << next;
      }
}

}  // namespace
}  // namespace lamina::interact
