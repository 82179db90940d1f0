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

/// What run_tools() did.
struct ToolRun {
  int64_t steps = 0;       ///< steps taken by this call
  bool converged = false;  ///< every tool ended and the model rested for sim::quiet_steps()
  sim::StepStats last;     ///< the last step's measurements
};

/// Called after each step with that step's measurements.
using StepObserver =
    std::function<void(const sim::Simulation&, const ToolDriver&, const sim::StepStats&)>;

/// Steps `sim` with `driver`'s tools until simulated time reaches `t_end_s`, or, if
/// `stop_at_rest`, until every tool has ended and the model has been at rest (sim::at_rest) for
/// sim::quiet_steps() steps in a row.
/// \note Throws lamina::Error (kInvalidInput) as apply_tools() for a tool that touches nothing.
ToolRun run_tools(sim::Simulation& sim, ToolDriver& driver, double t_end_s, bool stop_at_rest,
                  const StepObserver& per_step = {});

}  // namespace lamina::interact
