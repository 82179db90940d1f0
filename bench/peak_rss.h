#pragma once
// The process's peak resident memory, MB: every benchmark reports it.
#include <sys/resource.h>

namespace lamina::bench {

inline double peak_rss_mb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;  // Linux reports KiB
}

}  // namespace lamina::bench
