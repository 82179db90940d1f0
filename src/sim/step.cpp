// One time step in named, timed stages (after Box2D's b2World_Step): the force terms and
// integration (inside each integrator: force passes, then a node pass or a linear solve), the
// bounds check and its recovery, the measurements and the watch for instability.
#include <chrono>

#include "preconditioner.h"
#include "solver.h"

namespace lamina::sim {

using namespace detail;

namespace {

using Clock = std::chrono::steady_clock;

double us_since(Clock::time_point t) {
  return std::chrono::duration<double, std::micro>(Clock::now() - t).count();
}

// Measurements of the movable nodes against x_prev (after a recovered step, whose parts each
// measured only themselves).
Measured measure(const Simulation& sim) {
  const Solver& s = sim.solver();
  Partial acc;
  for (int32_t i : s.active_nodes)
    account(s, s.model->X, i, s.x_prev(i, 0), s.x_prev(i, 1), s.x_prev(i, 2), sim.x(i, 0),
            sim.x(i, 1), sim.x(i, 2), sim.v(i, 0), sim.v(i, 1), sim.v(i, 2), acc);
  Partials part;
  part[0] = acc;
  return combine(part, 1);
}

Measured advance(Simulation& sim, Integrator integrator, double h, bool save, int32_t& cg,
                 StepProfile& profile) {
  Solver& s = sim.solver();
  switch (integrator) {
    case Integrator::kSemiImplicitEuler: {
      // Beyond the stability limit: equal substeps below it (the rollback saves the start).
      if (s.explicit_limit_version != s.setup_version) {
        s.explicit_limit_s = explicit_dt_limit(sim);
        s.explicit_limit_version = s.setup_version;
      }
      const int64_t n = explicit_substeps(h, s.explicit_limit_s);
      Measured m = semi_implicit_euler(sim, h / static_cast<double>(n), save, profile);
      for (int64_t k = 1; k < n && m.ok; ++k)
        m = semi_implicit_euler(sim, h / static_cast<double>(n), false, profile);
      return n > 1 && m.ok ? measure(sim) : m;
    }
    case Integrator::kProjective:
      return projective_step(sim, h, save, profile);
    default:
      return implicit_euler(sim, h, save, cg, profile);
  }
}

// The movable nodes back to their state before the step.
void roll_back(Simulation& sim) {
  const Solver& s = sim.solver();
  for (int32_t i : s.active_nodes) {
    sim.x.row(i) = s.x_prev.row(i);
    sim.v.row(i) = s.v_prev.row(i);
  }
}

}  // namespace

double prepare_solver(Simulation& sim) {
  const auto t0 = Clock::now();
  Solver& s = sim.solver();
  const double h = s.options.dt_s;
  if (s.options.integrator == Integrator::kProjective)
    prepare_projective(s, h);
  else if (s.options.integrator == Integrator::kImplicitEuler)
    setup_multigrid(s, h);  // kAuto decides here, and the multigrid is built
  return us_since(t0) * 1e-6;
}

StepStats step(Simulation& sim) {
  Solver& s = sim.solver();
  const auto t0 = Clock::now();
  StepStats st;
  const double h = s.options.dt_s;
  const Integrator integrator = s.options.integrator;

  // Forces and integration.
  Measured m = advance(sim, integrator, h, /*save=*/true, st.cg_iterations, st.profile);

  // The finite check: roll back and redo, with two half steps of the same integrator, then
  // backward Euler (stable at any dt); if even that fails, stop the motion: never let a NaN out.
  if (!m.ok) {
    const auto tr = Clock::now();
    st.recovered = true;
    ++sim.recoveries;
    roll_back(sim);
    StepProfile spent;
    if (integrator == Integrator::kSemiImplicitEuler) {
      m = semi_implicit_euler(sim, 0.5 * h, false, spent);
      if (m.ok) m = semi_implicit_euler(sim, 0.5 * h, false, spent);
    }
    if (!m.ok || integrator != Integrator::kSemiImplicitEuler) {
      roll_back(sim);
      s.dv.setZero();  // the failed solve's answer is no guess for the next
      m = implicit_euler(sim, h, false, st.cg_iterations, spent);
    }
    if (!m.ok) {
      roll_back(sim);
      for (int32_t i : s.active_nodes) sim.v.row(i).setZero();
      s.dv.setZero();
      st.failed = true;
    }
    const Measured solve = m;
    m = measure(sim);
    m.solved = solve.solved, m.stalled = solve.stalled, m.residual = solve.residual;
    m.step_fraction = solve.step_fraction;
    st.profile.recover_us = us_since(tr);
  }
  sim.time_s += h;
  ++sim.steps;

  // Measurements.
  const auto tm = Clock::now();
  st.max_move_mm = std::sqrt(m.move2);
  st.max_speed_mm_per_s = std::sqrt(m.speed2);
  st.max_displacement_mm = std::max(std::sqrt(m.disp2), s.frozen_max_displacement_mm);
  st.kinetic_energy_j = m.ke * 1e-6;  // kg (mm/s)^2 -> J
  if (!s.layer_triangles.empty()) {
    const auto tris = static_cast<int64_t>(s.layer_triangles[0].size());
    st.skin_volume_mm3 =
        std::isnan(m.skin_volume6)
            ? layer_volume_now(s, sim.x, 0, tris >= 4 * kParallelSprings ? threads_for(s) : 1)
            : (s.frozen_layer_volume6_mm3[0] + m.skin_volume6) / 6.0;
    st.volume_change_pct =
        100.0 * (st.skin_volume_mm3 - s.rest_skin_volume_mm3) / s.rest_skin_volume_mm3;
  }
  st.converged = !st.failed && st.max_speed_mm_per_s < s.options.rest_speed_mm_per_s;
  st.solver_converged = m.solved;
  st.solver_residual = m.residual;
  st.step_fraction = m.step_fraction;
  watch_stability(sim, st, m.stalled);
  st.profile.measure_us = us_since(tm);
  st.step_us = us_since(t0);
  return st;
}

int64_t quiet_steps(const Simulation& sim, double quiet_s) {
  return std::max<int64_t>(3, static_cast<int64_t>(std::ceil(quiet_s / sim.options().dt_s - 1e-9)));
}

StepStats run_to_convergence(Simulation& sim, double quiet_s) {
  StepStats st;
  RestStreak rest{.needed = quiet_steps(sim, quiet_s)};
  for (int64_t k = 0; k < sim.options().max_steps; ++k) {
    st = step(sim);
    if (st.failed) break;  // held still by force, not at rest
    if (rest.update(st)) return st;
  }
  st.converged = false;
  return st;
}

}  // namespace lamina::sim
