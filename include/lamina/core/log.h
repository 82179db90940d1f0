#pragma once
/// \file
/// One channel for messages: an spdlog logger named "lamina" on stderr, so that stdout stays
/// clean for `--json` output and for programs that embed the library.

#include <spdlog/spdlog.h>

#include <utility>

namespace lamina::log {

/// The library's logger (stderr), created on first use. Embedders may add sinks to it.
spdlog::logger& logger();

/// Sets the verbosity: -1 = errors only, 0 = warnings and errors, 1 = info (default), 2 = debug.
void set_verbosity(int level);

template <class... Args>
void debug(spdlog::format_string_t<Args...> fmt, Args&&... args) {
  logger().debug(fmt, std::forward<Args>(args)...);
}
template <class... Args>
void info(spdlog::format_string_t<Args...> fmt, Args&&... args) {
  logger().info(fmt, std::forward<Args>(args)...);
}
template <class... Args>
void warn(spdlog::format_string_t<Args...> fmt, Args&&... args) {
  logger().warn(fmt, std::forward<Args>(args)...);
}
template <class... Args>
void error(spdlog::format_string_t<Args...> fmt, Args&&... args) {
  logger().error(fmt, std::forward<Args>(args)...);
}

}  // namespace lamina::log
