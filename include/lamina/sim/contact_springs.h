#pragma once
/// \file
/// Springs set from outside a simulation every step: how a world (world.h) holds a node at a
/// point of another body's skin inside the node's own implicit step.

#include <cstdint>
#include <vector>

#include "lamina/sim/simulation.h"

namespace lamina::sim {

/// Contact springs: extra zero-length-spring stiffness on these nodes, N/m, towards their rest
/// positions, replacing the set given last time (an empty list removes them). A spring to any
/// other point T is this stiffness k plus the constant force k (T - X) in f_ext: that is how a
/// world holds a node at a point of another skin inside the implicit step, where a stiff spring
/// is stable. Cheap every step: what a prefactored solve or the multigrid's setup depend on is
/// left as it is (the multigrid's smoother does not see the springs; Jacobi's diagonal does).
/// Semi-implicit Euler re-derives its stability limit. The energy watch takes it as a tool.
/// \note Throws lamina::Error (kInvalidInput) for a node outside the model, a count that differs
///   from the node count, a stiffness that is negative or not finite, or any spring on a
///   simulation stepped by projective dynamics (its factor holds the support).
void set_contact_stiffness(Simulation& sim, const std::vector<int32_t>& nodes,
                           const std::vector<double>& stiffness_n_per_m);

}  // namespace lamina::sim
