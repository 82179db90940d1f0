#pragma once
/// \file
/// The plainest explicit step, the reference `lamina bench` measures Lamina's hot loop against
/// in the same run (issue 17): positions as an array of xyz, one pass over the springs
/// accumulating each spring's force on both ends, one pass integrating. One thread, double
/// precision, no measurements, no rollback: what a newcomer would write in an afternoon.

#include <cstdint>
#include <vector>

#include "lamina/sim/simulation.h"

namespace lamina::cli {

struct PlainLoop {
  std::vector<double> x, v, f;   ///< xyz per node: positions (mm), velocities, spring forces
  std::vector<double> f_other;   ///< xyz per node: external force + gravity (mN), fixed per run
  std::vector<double> h_over_m;  ///< dt / mass per node (0 for a node that does not move)
  std::vector<double> damping;   ///< gamma + alpha m per node, kg/s
  std::vector<int32_t> si, sj;   ///< spring ends
  std::vector<double> rest_mm, k_n_per_m;
  double dt_s = 0.0;
};

/// The plain loop of `sim`'s network at its current state, with its fixed nodes, external forces,
/// masses, damping and spring constants. Throws lamina::Error for what the plain loop does not
/// model (tetrahedra, the volume term, support springs, local mode) or a dt beyond the explicit
/// limit (Lamina would substep).
PlainLoop make_plain_loop(const sim::Simulation& sim);

/// One semi-implicit Euler step: v += dt/m (f_springs + f_ext - damping v); x += dt v.
void plain_step(PlainLoop& p);

}  // namespace lamina::cli
