#pragma once
/// \file
/// One channel for messages: spdlog on stderr, so stdout stays clean for --json output.

#include <spdlog/spdlog.h>

namespace lamina::log {

/// Sets the verbosity: 0 = warnings and errors, 1 = info (default), 2 = debug.
void set_verbosity(int level);

using spdlog::debug;
using spdlog::error;
using spdlog::info;
using spdlog::warn;

}  // namespace lamina::log
