// Semi-implicit (symplectic) Euler, the paper's integrator: v += dt a(x, v); x += dt v.
// The force passes (springs, then tetrahedra) write per-element buffers; then each movable node
// gathers its forces, integrates, checks and measures itself in one sweep. With save, the
// movable nodes' old state goes to x_prev/v_prev first (the step's rollback).
#include <chrono>

#include "force_terms.h"
#include "solver.h"

namespace lamina::sim::detail {
namespace {
using Clock = std::chrono::steady_clock;
double us_since(Clock::time_point t) {
  return std::chrono::duration<double, std::micro>(Clock::now() - t).count();
}
}  // namespace

Measured semi_implicit_euler(Simulation& sim, double dt, bool save, StepProfile& profile) {
  Solver& s = sim.solver();
  if (lanes_apply(s)) return semi_implicit_euler_lanes(sim, dt, save, profile);
  const int T = threads_for(s);
  const auto t0 = Clock::now();
  if (s.material.volume_stiffness_kpa > 0.0) update_volume_term(s, sim.x, T);
  const bool compact = s.compact.on;
  if (s.tets.on)
    tet_pass(s, sim.x, /*linearise=*/false, T);  // the springs are the tetrahedra's edges
  else if (compact)
    compact_spring_pass(s, sim.x, T);  // local mode's few springs, copied together
  else
    spring_pass(s, sim.x, T);
  const auto t1 = Clock::now();
  profile.forces_us += std::chrono::duration<double, std::micro>(t1 - t0).count();

  NodeState state(sim, s);
  Partials part;
  for_slices(static_cast<int64_t>(s.active_nodes.size()), T,
             [&](int64_t begin, int64_t end, int t) {
               Partial acc;
               for (int64_t q = begin; q < end; ++q) {
                 const int32_t i = s.active_nodes[q];
                 double fx, fy, fz;
                 if (compact) {
                   node_force_but_elements(s, sim, i, /*damped=*/true, fx, fy, fz);
                   gather_compact_springs(s, q, fx, fy, fz);
                 } else {
                   node_force(s, sim, i, /*damped=*/true, fx, fy, fz);
                 }
                 const double h_m = dt / s.mass_kg[i];
                 finish_node(s, state, i, dt, save, sim.v(i, 0) + h_m * fx, sim.v(i, 1) + h_m * fy,
                             sim.v(i, 2) + h_m * fz, acc);
               }
               part[t] = acc;
             });
  profile.integrate_us += us_since(t1);
  return combine(part, T);
}

}  // namespace lamina::sim::detail
