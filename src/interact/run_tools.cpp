#include "lamina/interact/run_tools.h"

namespace lamina::interact {

ToolRun run_tools(sim::Simulation& sim, ToolDriver& driver, double t_end_s, bool stop_at_rest,
                  const StepObserver& per_step) {
  const double release = last_tool_end(driver);
  const int64_t needed = sim::quiet_steps(sim);
  ToolRun run;
  int64_t quiet = 0;
  // 1e-9 s: a time reached by adding dt many times lands a rounding error short of t_end_s.
  while (sim.time_s < t_end_s - 1e-9) {
    apply_tools(sim, driver);
    run.last = sim::step(sim);
    ++run.steps;
    if (per_step) per_step(sim, driver, run.last);
    // Not before the last tool has ended: a model held under a constant load is at rest too.
    quiet = sim.time_s > release && sim::at_rest(run.last) ? quiet + 1 : 0;
    if (stop_at_rest && quiet >= needed) {
      run.converged = true;
      break;
    }
  }
  return run;
}

}  // namespace lamina::interact
