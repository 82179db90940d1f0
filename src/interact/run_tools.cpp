#include "lamina/interact/run_tools.h"

#include <algorithm>
#include <cmath>

namespace lamina::interact {

RestWatch rest_watch(const sim::Simulation& sim, const ToolDriver& driver) {
  const double tools_end = last_tool_end(driver);
  double last_start = 0.0;
  for (const Tool& t : driver.tools) last_start = std::max(last_start, t.start_s);
  // A tool that never lets go is followed until the model rests under its load.
  return {.settle_from_s = std::isfinite(tools_end) ? tools_end : last_start,
          .quiet = {.needed = sim::quiet_steps(sim)}};
}

ToolRun run_tools(sim::Simulation& sim, ToolDriver& driver, double t_end_s, bool stop_at_rest,
                  const StepObserver& per_step, const Stepper& step) {
  RestWatch rest = rest_watch(sim, driver);
  ToolRun run;
  // 1e-9 s: a time reached by adding dt many times lands a rounding error short of t_end_s.
  while (sim.time_s < t_end_s - 1e-9 && sim.steps < sim.options().max_steps) {
    const double start = sim.time_s;
    if (step) {
      run.last = step();
    } else {
      apply_tools(sim, driver);
      run.last = sim::step(sim);
    }
    ++run.steps;
    if (per_step) per_step(sim, driver, run.last);
    if (run.last.unstable != sim::Instability::kNone) break;  // the caller says so
    if (rest.update(start, run.last) && stop_at_rest) {
      run.converged = true;
      break;
    }
  }
  return run;
}

}  // namespace lamina::interact
