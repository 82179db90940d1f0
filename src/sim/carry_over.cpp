// A running simulation carried over to its model cut. The slow half (the simulation of the cut
// model made and its solver prepared) reads only copies, so a real-time loop can run it on
// another thread while it steps on; the state is then carried over at once.
#include "lamina/sim/carry_over.h"

#include <string>

#include "lamina/core/error.h"
#include "lamina/model/cut_tetrahedra.h"
#include "solver.h"

namespace lamina::sim {
namespace {

void check_origin(const Model& before, const Model& cut, const std::vector<int32_t>& origin) {
  if (origin.size() != static_cast<size_t>(cut.node_count()))
    throw invalid_input("cut", "origin has " + std::to_string(origin.size()) +
                                   " entries for a model of " + std::to_string(cut.node_count()) +
                                   " nodes");
  for (int32_t o : origin)
    if (o < 0 || o >= before.node_count())
      throw invalid_input(
          "cut", "origin names node " + std::to_string(o) + ", not one of the simulated model's");
}

}  // namespace

CarrySource carry_source(const Simulation& sim) {
  CarrySource c{.material = sim.material(),
                .options = sim.options(),
                .support_n_per_m = sim.solver().support.support_n_per_m,
                .state = capture_state(sim),
                .tets_id = sim.solver().tets.id};
  // The preconditioner the simulation chose, kept: the cut changes a few tetrahedra, not which
  // one suits the model (and "auto" would solve a trial system again at every cut).
  if (c.options.integrator == Integrator::kImplicitEuler &&
      c.options.preconditioner == Preconditioner::kAuto && sim.steps > 0)
    c.options.preconditioner =
        uses_multigrid(sim) ? Preconditioner::kMultigrid : Preconditioner::kJacobi;
  return c;
}

SimState carried_state(const SimState& was, const Model& before, const Model& cut,
                       const std::vector<int32_t>& origin) {
  check_origin(before, cut, origin);
  const int32_t n = cut.node_count();
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
  return now;
}

Simulation made_for_cut(const CarrySource& from, const Model& before, const Model& cut,
                        const std::vector<int32_t>& origin, bool prepare) {
  check_origin(before, cut, origin);
  // The tetrahedra the cut left as they were keep their constants: identifying every one again
  // (a 6x6 inverse each) was most of an event beyond paper size (docs/benchmarks.md).
  detail::KnownTets known;
  if (from.tets_id && cut.has_tets())
    known = {.before = from.tets_id,
             .tables = {.before = from.tets_id.get(),
                        .tets = model::same_tets(before, cut, origin),
                        .springs = model::same_springs(before, cut, origin)}};
  Simulation out =
      detail::make_simulation(cut, from.material, from.options, known.before ? &known : nullptr);
  // Support, divided among a node's copies by their masses (a cut adds no hold on the organ).
  if (!from.support_n_per_m.empty()) {
    std::vector<int32_t> nodes;
    std::vector<double> k;
    for (int32_t i = 0; i < cut.node_count(); ++i) {
      const double own = from.support_n_per_m[static_cast<size_t>(origin[i])];
      if (own == 0.0) continue;
      nodes.push_back(i);
      k.push_back(own * model::copy_share(before, cut, origin, i));
    }
    support_nodes(out, nodes, k);
  }
  restore_state(out, carried_state(from.state, before, cut, origin));
  if (prepare) prepare_solver(out);
  return out;
}

Simulation carry_over(const Simulation& sim, const Model& cut, const std::vector<int32_t>& origin) {
  return made_for_cut(carry_source(sim), sim.model(), cut, origin, /*prepare=*/false);
}

}  // namespace lamina::sim
