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

/// The period of a duty done `hz` times a second.
inline ServeClock::duration every(double hz) {
  return std::chrono::duration_cast<ServeClock::duration>(std::chrono::duration<double>(1.0 / hz));
}

/// Whether a frame is due at `next` (then `next` moves on by `period`, from now after a stall:
/// the frame goes at once, with no burst of the ones missed).
inline bool frame_due(ServeClock::time_point& next, ServeClock::duration period) {
  const auto now = ServeClock::now();
  if (now < next) return false;
  next += period;
  if (next < now) next = now;
  return true;
}

/// The next time of a periodic duty, without a burst after a stall.
inline void advance(ServeClock::time_point& next, ServeClock::duration period) {
  next += period;
  if (next < ServeClock::now()) next = ServeClock::now() + period;
}

}  // namespace lamina::net
