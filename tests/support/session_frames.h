#pragma once
// Driving a viewer session (the one-organ one or the world's) frame by frame in a test: frames
// until a condition holds, or for a span of simulated time. The session steps in its own thread,
// so the tests wait on what it did, not on the clock.
#include <chrono>
#include <thread>

namespace lamina::test {

/// Frames until `done()` (or the wall-clock limit), a few milliseconds apart.
template <class Session, class Done>
bool frames_until(Session& s, Done done, double limit_s = 60.0) {
  const auto t0 = std::chrono::steady_clock::now();
  while (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < limit_s) {
    if (!s.frame()) return done();
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(3));
  }
  return false;
}

/// Frames for `seconds` of simulated time (the session's snapshot().time_s).
template <class Session>
bool simulate_for(Session& s, double seconds) {
  const double until = s.snapshot().time_s + seconds;
  return frames_until(s, [&] { return s.snapshot().time_s >= until; });
}

/// Frames until the session's world is at rest (its own rest: a velocity test) with `rested()`
/// true, or for `seconds` of simulated time: "back at rest within N s" without waiting out the
/// N s once it holds. For a state the test waits to reach, not one it checks lasts.
template <class Session, class Rested>
bool simulate_until_rest(Session& s, double seconds, Rested rested) {
  const double until = s.snapshot().time_s + seconds;
  return frames_until(
      s, [&] { return s.snapshot().time_s >= until || (s.snapshot().converged && rested()); });
}

}  // namespace lamina::test
