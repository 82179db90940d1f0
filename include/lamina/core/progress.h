#pragma once
/// \file
/// Progress reporting for long work (a clinical mask takes seconds to build): the caller decides
/// how to show it (a CLI line on stderr, a GUI progress bar, nothing).

#include <functional>
#include <string_view>

namespace lamina {

/// Called with a short stage name and the overall fraction done in [0, 1].
using ProgressFn = std::function<void(std::string_view stage, double fraction)>;

/// Calls `fn` if it is set.
inline void report_progress(const ProgressFn& fn, std::string_view stage, double fraction) {
  if (fn) fn(stage, fraction);
}

}  // namespace lamina
