#pragma once
/// \file
/// A stepping thread's count of the times a caller held a lock it needed, and its longest wait:
/// a real-time loop's callers hold its locks only to copy a few values, so a wait of more than
/// milliseconds is a bug on any machine (the serve tests check it).

#include <algorithm>
#include <cstdint>
#include <mutex>

#include "lamina/core/clock.h"

namespace lamina {

struct LockWaits {
  int64_t count = 0;
  double longest_us = 0.0;

  /// Locks `lock`, counting the wait when another thread holds it.
  void acquire(std::unique_lock<std::mutex>& lock) {
    if (lock.try_lock()) return;
    const Clock::time_point t0 = Clock::now();
    lock.lock();
    ++count;
    longest_us = std::max(longest_us, 1e6 * seconds_since(t0));
  }
};

}  // namespace lamina
