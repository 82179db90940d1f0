#pragma once
// The reference paper's setup on a model and a plain stepping loop over it, shared by
// `lamina figures` and `lamina bench`.

#include <cstdint>
#include <functional>
#include <vector>

#include "lamina/interact/tools.h"
#include "lamina/model/model.h"
#include "lamina/sim/simulation.h"

namespace lamina::cli {

/// A model, its boundary, parameters and tools.
struct Setup {
  const Model* model = nullptr;
  std::vector<int32_t> fixed;
  sim::Material material;
  sim::SolverOptions solver;
  interact::RoutingOptions routing;
  std::vector<interact::Tool> tools;
};

/// The paper's setup on `model`: K = 3 N/m, gamma = 3 kg/s, unit masses, semi-implicit Euler at
/// dt = 0.01 s, local mode, N = 4, P = 4, the default poke (0.4 N for 1 s on the most anterior
/// skin node) and the posterior 10 mm held.
Setup paper_setup(const Model& model);

struct RunStats {
  double wall_s = 0.0;  ///< wall time of the stepping loop
  int64_t steps = 0;
  bool converged = false;
};

/// Steps `setup` until t_end_s, or (if stop_at_rest) until every tool has ended and the model has
/// come to rest (interact::run_tools, interact::RestWatch). Calls per_step after each step with
/// that step's measurements.
RunStats simulate(const Setup& setup, double t_end_s, bool stop_at_rest,
                  const std::function<void(const sim::Simulation&, const interact::ToolDriver&,
                                           const sim::StepStats&)>& per_step = {});

}  // namespace lamina::cli
