#include "paper_run.h"

#include <chrono>

#include "lamina/interact/run_tools.h"
#include "lamina/io/scene.h"

namespace lamina::cli {

using Clock = std::chrono::steady_clock;

// The paper's scene with its constants as they are (nothing for resolve_material() to decide:
// no E, nu or damping ratio), so the model stays shared and unchanged across the figures'
// experiments; the same defaults and checks as io::prepare_scene().
Setup paper_setup(const Model& m) {
  io::Scene scene = io::paper_scene();  // the paper's poke (0.4 N, 0-1 s) and boundary
  io::resolve_scene_defaults(scene, m);
  io::check_scene_against_model(scene, m);
  Setup s;
  s.model = &m;
  s.fixed = io::fixed_scene_nodes(scene, m);
  s.solver.mode = sim::Mode::kLocal;
  s.tools = scene.tools;
  return s;
}

RunStats simulate(const Setup& setup, double t_end_s, bool stop_at_rest,
                  const std::function<void(const sim::Simulation&, const interact::ToolDriver&,
                                           const sim::StepStats&)>& per_step) {
  sim::Simulation s = sim::make_simulation(*setup.model, setup.material, setup.solver);
  sim::fix_nodes(s, setup.fixed);
  interact::ToolDriver driver{.tools = setup.tools, .routing = setup.routing};
  RunStats r;
  const auto t0 = Clock::now();
  r.converged = interact::run_tools(s, driver, t_end_s, stop_at_rest, per_step).converged;
  r.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  r.steps = s.steps;
  return r;
}

}  // namespace lamina::cli
