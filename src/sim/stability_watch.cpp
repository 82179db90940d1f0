// The watch for instability: what makes a simulation's result no longer physics, counted step
// by step (issue 31: never silently wrong). A step that fails its bounds check is already
// redone inside step(); what reaches here is what a redo could not mend.
#include <cmath>
#include <type_traits>

#include "force_terms.h"
#include "solver.h"

namespace lamina::sim {

const char* describe(Instability reason) {
  switch (reason) {
    case Instability::kStepsFailed:
      return "steps failed even with backward Euler (a value was not finite or a node moved "
             "farther from rest than twice the organ's size)";
    case Instability::kEnergyGrowth:
      return "the energy grew while no tool acted (damped tissue only loses energy)";
    case Instability::kSolverStalled:
      return "the implicit solver missed its tolerance step after step (by more than 100x)";
    case Instability::kNone:
      break;
  }
  return "stable";
}

namespace detail {

namespace {

// Energy below this (1 uJ: a 1 mN push over 1 mm) is round-off's, not a motion's.
constexpr double kEnergyFloorJ = 1e-6;

bool tool_acts(const Simulation& sim) {
  const Solver& s = sim.solver();
  // nodes held, moved, released
  if (s.watch.setup_version != s.setup_version || s.watch.held_moves != s.held_moves) return true;
  for (int32_t i : s.active_nodes)
    if (sim.f_ext(i, 0) != 0.0 || sim.f_ext(i, 1) != 0.0 || sim.f_ext(i, 2) != 0.0) return true;
  return false;
}

// Gravity's potential relative to rest, J: - sum m g . (x - X) over the nodes that move.
double gravity_energy_j(const Simulation& sim) {
  const Solver& s = sim.solver();
  const Eigen::Vector3d g = s.material.gravity_mm_per_s2;
  if (g.isZero()) return 0.0;
  double e = 0.0;
  for (int32_t i : s.active_nodes)
    e -= s.mass_kg[i] * g.dot((sim.x.row(i) - s.model->X.row(i)).transpose());
  return e * 1e-6;  // kg mm^2/s^2 -> J
}

// The elastic energy at sim.x, J, with the springs between nodes that do not move taken from
// their cache (Solver::frozen_spring_energy_mj, made again after refresh_frozen_positions()): in
// local mode they are most of the model (the paper's poke at paper size: 9,072 of 9,979
// springs), and summing them again every kEnergyCheckSteps was 9% of its run to rest.
double elastic_energy_now(Simulation& sim) {
  Solver& s = sim.solver();
  if (s.frozen_spring_energy_stale) {
    s.frozen_spring_energy_mj =
        EdgeSprings::on(s) ? EdgeSprings::part_energy_mj(s, sim.x, false) : 0.0;
    s.frozen_spring_energy_stale = false;
  }
  double e = 0.0;
  for_each_term(Terms{}, s, [&](auto term) {
    using Term = decltype(term);
    if constexpr (std::is_same_v<Term, EdgeSprings>)
      e += Term::part_energy_mj(s, sim.x, true) + s.frozen_spring_energy_mj;
    else
      e += Term::energy_mj(s, sim.x);
  });
  return e * 1e-6;  // mN mm = 1e-6 J
}

// Total energy without input can only fall (damping, and backward Euler's own dissipation);
// semi-implicit Euler's discrete energy wobbles about a conserved one by a few percent at the
// dt it allows. Kinetic energy alone would not do: it rises whenever stored energy is let go.
// So: once no tool has acted for kEnergyCheckSteps, the total is taken, and every
// kEnergyCheckSteps after it may not exceed that start by more than its own size.
bool energy_grew(Simulation& sim, const StepStats& st) {
  Solver& s = sim.solver();
  StabilityWatch& w = s.watch;
  if (tool_acts(sim)) {
    w.setup_version = s.setup_version;
    w.held_moves = s.held_moves;
    w.quiet_steps = 0;
    w.armed = false;
    return false;
  }
  if (++w.quiet_steps % kEnergyCheckSteps != 0) return false;
  const double e = st.kinetic_energy_j + elastic_energy_now(sim) + gravity_energy_j(sim);
  if (!w.armed) {
    w.armed = true;
    w.start_j = e;
    return false;
  }
  return !std::isfinite(e) || e - w.start_j > std::max(std::abs(w.start_j), kEnergyFloorJ);
}

}  // namespace

void watch_stability(Simulation& sim, StepStats& st, bool stalled) {
  StabilityWatch& w = sim.solver().watch;
  w.failed_streak = st.failed ? w.failed_streak + 1 : 0;
  w.unsolved_streak = stalled ? w.unsolved_streak + 1 : 0;
  if (w.latched == Instability::kNone) {
    if (w.failed_streak >= kFailedStepsToUnstable)
      w.latched = Instability::kStepsFailed;
    else if (w.unsolved_streak >= kUnsolvedStepsToUnstable)
      w.latched = Instability::kSolverStalled;
    else if (energy_grew(sim, st))
      w.latched = Instability::kEnergyGrowth;
  }
  st.unstable = w.latched;
}

}  // namespace detail
}  // namespace lamina::sim
