#pragma once
/// \file
/// Wall-clock timing for reports and logs: one steady clock and one way to read it.

#include <chrono>

namespace lamina {

using Clock = std::chrono::steady_clock;

/// Wall seconds since the first call in this process: the real-time loops' clock (the one-organ
/// loop's and the world's), shared by their files so that the times they take compare.
inline double now_s() {
  static const Clock::time_point t0 = Clock::now();
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// Wall seconds since `t0`.
inline double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

}  // namespace lamina
