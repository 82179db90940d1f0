#pragma once
/// \file
/// A running simulation carried over to its model cut (model::cut_tetrahedra): the cut changes
/// the nodes and the tetrahedra, not the motion.

#include <cstdint>
#include <memory>
#include <vector>

#include "lamina/model/model.h"
#include "lamina/sim/simulation.h"

namespace lamina::sim {

/// A simulation of `cut` that continues `sim`: the same material and solver options, each
/// node's position, velocity, external force, fixed and movable flags on every copy of it, the
/// clock and step count, and each node's support divided among its copies as its mass is.
/// @param[in] sim     a simulation of the model `cut` was cut from
/// @param[in] cut     the cut model (it must outlive the result)
/// @param[in] origin  #cut nodes: the node of sim's model each came from
/// \note Throws lamina::Error (kInvalidInput) if origin does not match the two models.
Simulation carry_over(const Simulation& sim, const Model& cut, const std::vector<int32_t>& origin);

/// carry_over() in two halves, for a loop that steps on while a cut is made
/// (world::OrganLoop): what a simulation of the cut model needs from the one it continues,
/// copied (carry_source(), quick), then the simulation made from the copies alone on any thread
/// (made_for_cut(), slow: the tetrahedra identified, the solver prepared), then the state of the
/// moment put in (restore_state(made, carried_state(capture_state(sim), ...)), quick).
struct CarrySource {
  Material material;
  SolverOptions options;                ///< with the preconditioner sim chose, kept
  std::vector<double> support_n_per_m;  ///< per node of sim's model
  SimState state;                       ///< sim's when copied
  /// sim's tetrahedra's constants (shared, never changed; null without tetrahedra): the ones
  /// the cut leaves as they were keep theirs (model::same_tets())
  std::shared_ptr<const model::TetIdentification> tets_id;
};
CarrySource carry_source(const Simulation& sim);

/// A state of the model `before` carried over to `cut`, node by node (each load divided among
/// a node's copies as its mass is).
SimState carried_state(const SimState& was, const Model& before, const Model& cut,
                       const std::vector<int32_t>& origin);

/// A simulation of `cut` from `from` (which was of `before`), at from.state carried over; with
/// `prepare`, its solver prepared (sim::prepare_solver(): the multigrid built) for that state's
/// fixed and moving nodes, which a later state with the same ones keeps.
Simulation made_for_cut(const CarrySource& from, const Model& before, const Model& cut,
                        const std::vector<int32_t>& origin, bool prepare);

}  // namespace lamina::sim
