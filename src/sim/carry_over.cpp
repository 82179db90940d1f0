#include "lamina/sim/carry_over.h"

#include <string>

#include "lamina/core/error.h"
#include "lamina/model/cut_tetrahedra.h"
#include "solver.h"

namespace lamina::sim {

Simulation carry_over(const Simulation& sim, const Model& cut, const std::vector<int32_t>& origin) {
  const Model& before = sim.model();
  const int32_t n = cut.node_count();
  if (origin.size() != static_cast<size_t>(n))
    throw invalid_input("cut", "origin has " + std::to_string(origin.size()) +
                                   " entries for a model of " + std::to_string(n) + " nodes");
  for (int32_t o : origin)
    if (o < 0 || o >= before.node_count())
      throw invalid_input(
          "cut", "origin names node " + std::to_string(o) + ", not one of the simulated model's");

  // The preconditioner the simulation chose, kept: the cut changes a few tetrahedra, not which
  // one suits the model (and "auto" would solve a trial system again at every cut).
  SolverOptions options = sim.options();
  if (options.integrator == Integrator::kImplicitEuler &&
      options.preconditioner == Preconditioner::kAuto && sim.steps > 0)
    options.preconditioner =
        uses_multigrid(sim) ? Preconditioner::kMultigrid : Preconditioner::kJacobi;
  Simulation out = make_simulation(cut, sim.material(), options);
  // Support, divided among a node's copies by their masses (a cut adds no hold on the organ).
  const std::vector<double>& support = sim.solver().support.support_n_per_m;
  if (!support.empty()) {
    std::vector<int32_t> nodes;
    std::vector<double> k;
    for (int32_t i = 0; i < n; ++i) {
      const double own = support[static_cast<size_t>(origin[i])];
      if (own == 0.0) continue;
      nodes.push_back(i);
      k.push_back(own * model::copy_share(before, cut, origin, i));
    }
    support_nodes(out, nodes, k);
  }
  const SimState was = capture_state(sim);
  SimState now;
  now.x.resize(n, 3), now.v.resize(n, 3), now.f_ext.resize(n, 3), now.dv.resize(n, 3);
  now.fixed.resize(static_cast<size_t>(n)), now.movable.resize(static_cast<size_t>(n));
  for (int32_t i = 0; i < n; ++i) {
    const int32_t o = origin[static_cast<size_t>(i)];
    now.x.row(i) = was.x.row(o);
    now.v.row(i) = was.v.row(o);
    // A tool's load on a node is divided among its copies as its mass is: the total is kept.
    now.f_ext.row(i) = was.f_ext.row(o) * model::copy_share(before, cut, origin, i);
    now.dv.row(i) = was.dv.row(o);
    now.fixed[static_cast<size_t>(i)] = was.fixed[static_cast<size_t>(o)];
    now.movable[static_cast<size_t>(i)] = was.movable[static_cast<size_t>(o)];
  }
  now.time_s = was.time_s;
  now.steps = was.steps;
  now.recoveries = was.recoveries;
  restore_state(out, now);
  return out;
}

}  // namespace lamina::sim
