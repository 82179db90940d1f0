#pragma once
/// \file
/// A running simulation carried over to its model cut (model::cut_tetrahedra): the cut changes
/// the nodes and the tetrahedra, not the motion.

#include <cstdint>
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

}  // namespace lamina::sim
