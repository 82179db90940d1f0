#pragma once
/// \file
/// The plain stepping loop of a scene: tools act by their times, the model responds, and the run
/// ends when every tool has ended and the model has come to rest. `lamina figures`, `lamina
/// bench`, the Python module and the C API share it.

#include <cstdint>
#include <functional>

#include "lamina/interact/tools.h"
#include "lamina/sim/simulation.h"

namespace lamina::interact {

/// When a scene's run is over: every tool has let go (or, for a tool that never lets go, the
/// last one has started) and the model has been at rest (sim::at_rest) for sim::quiet_steps()
/// steps in a row. One quiet step is not enough: velocities pass through zero when a tool is
/// released and at every turn of an oscillation. `lamina run` and run_tools() share it.
struct RestWatch {
  double settle_from_s = 0.0;  ///< quiet steps count from this simulated time
  sim::RestStreak quiet;       ///< sim's settling test, counted from settle_from_s

  /// Counts a step that started at `start_time_s` and measured `stats`.
  /// @return true when the model has come to rest
  bool update(double start_time_s, const sim::StepStats& stats) {
    if (start_time_s < settle_from_s) {
      quiet.streak = 0;
      return false;
    }
    return quiet.update(stats);
  }
};

/// The rest test for `sim` driven by `driver`'s tools.
RestWatch rest_watch(const sim::Simulation& sim, const ToolDriver& driver);

/// What run_tools() did.
struct ToolRun {
  int64_t steps = 0;       ///< steps taken by this call
  bool converged = false;  ///< every tool ended and the model rested for sim::quiet_steps()
  sim::StepStats last;     ///< the last step's measurements
};

/// Called after each step with that step's measurements.
using StepObserver =
    std::function<void(const sim::Simulation&, const ToolDriver&, const sim::StepStats&)>;

/// One step of the tools and the model, returning the model's measurements: apply_tools() then
/// sim::step() for a simulation alone, world::step() for the body of a world of one (Python's
/// Simulation), which does the same.
using Stepper = std::function<sim::StepStats()>;

/// Steps `sim` with `driver`'s tools until simulated time reaches `t_end_s` or the solver's
/// max_steps, or, if `stop_at_rest`, until the model has come to rest (RestWatch), or until the
/// simulation becomes unstable (ToolRun::last.unstable, which the caller must report).
/// @param[in] step  takes one step of `sim` with `driver`'s tools; empty: apply_tools() then
///   sim::step()
/// \note Throws lamina::Error (kInvalidInput) as apply_tools() for a tool that touches nothing.
ToolRun run_tools(sim::Simulation& sim, ToolDriver& driver, double t_end_s, bool stop_at_rest,
                  const StepObserver& per_step = {}, const Stepper& step = {});

}  // namespace lamina::interact
