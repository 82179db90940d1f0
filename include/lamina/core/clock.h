#pragma once
/// \file
/// Wall-clock timing for reports and logs: one steady clock and one way to read it.

#include <chrono>

namespace lamina {

using Clock = std::chrono::steady_clock;

/// Wall seconds since `t0`.
inline double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

}  // namespace lamina
