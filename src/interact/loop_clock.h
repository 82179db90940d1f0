#pragma once
// The real-time loop's wall clock (private to module interact): seconds since the first call,
// shared by the loop's files so that their times compare.
#include <chrono>

namespace lamina::interact {

inline double now_s() {
  static const std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace lamina::interact
