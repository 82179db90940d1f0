#include "lamina/core/log.h"

#include <spdlog/sinks/stdout_color_sinks.h>

namespace lamina::log {

spdlog::logger& logger() {
  // stderr, never spdlog's default (stdout) logger: --json output and embedding programs own
  // stdout. Thread-safe static initialisation.
  static std::shared_ptr<spdlog::logger> l = [] {
    auto made = spdlog::stderr_color_mt("lamina");
    made->set_pattern("%^%l%$: %v");
    return made;
  }();
  return *l;
}

void set_verbosity(int level) {
  logger().set_level(level < 0    ? spdlog::level::err
                     : level == 0 ? spdlog::level::warn
                     : level == 1 ? spdlog::level::info
                                  : spdlog::level::debug);
}

}  // namespace lamina::log
