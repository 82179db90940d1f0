#pragma once
// The material and solver fields as the viewers' panels edit them (Dear ImGui, inside a frame):
// the one-organ view's and the world view's for the body chosen.
#include "lamina/sim/simulation.h"

namespace lamina::cli {

/// The material's fields; true when one changed. `last_volume_kpa`: the volume term's last value,
/// given back when its box is ticked again.
bool material_widgets(sim::Material& material, double& last_volume_kpa);

/// The solver's fields but the rate (the caller's): integrator, mode, dt, rest speed, iterations.
/// fixed_dt_s > 0: the step is the caller's (1 / rate in real time), shown greyed under
/// `fixed_dt_label` instead of solver.dt_s.
/// @return true when one changed
bool solver_widgets(sim::SolverOptions& solver, double fixed_dt_s, const char* fixed_dt_label);

}  // namespace lamina::cli
