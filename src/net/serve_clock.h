#pragma once
// lamina serve's wall clock: the network thread's periodic duties, its stroke pauses and the
// cost of packing a message are all timed on it.
#include <chrono>

namespace lamina::net {

using ServeClock = std::chrono::steady_clock;

/// A duration of the serve clock in seconds.
inline double seconds(ServeClock::duration d) {
  return std::chrono::duration<double>(d).count();
}

}  // namespace lamina::net
