#pragma once
/// \file
/// A cut in two halves, for a loop that steps on while the cut is made (the one-organ
/// OrganLoop and the world's loop alike): prepare_cut() divides the model and makes a
/// simulation of the cut model, its solver prepared, from copies alone and on any thread (tens to
/// hundreds of milliseconds); take_cut() then puts the state of the moment and the tools into
/// it between two steps (a fraction of a millisecond). Done at once, the two are a cut made on
/// the stepping thread (world::cut_body).

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "lamina/interact/tools.h"
#include "lamina/model/cut_tetrahedra.h"
#include "lamina/sim/carry_over.h"

namespace lamina::interact {

/// A cut made, not yet taken in.
struct PreparedCut {
  std::shared_ptr<const Model> cut;    ///< the cut model; null when the blade divided nothing
  std::vector<int32_t> origin;         ///< per node of *cut, the node it came from
  model::CutReport report;             ///< the structures crossed at rest
  std::optional<sim::Simulation> sim;  ///< a simulation of *cut, its solver prepared
};

/// The slow half: the blade drawn at `from`'s positions of `model` (its upper end along `path`,
/// reaching depth_mm along `direction`, carried to rest: cut_model_now()) divides a copy of the
/// model, and a simulation of the cut model is made from `from` (sim::made_for_cut).
/// \note Throws lamina::Error (kInvalidInput) as cut_now() does: a blade scalpel_problem()
///   refuses, a model without tetrahedra.
PreparedCut prepare_cut(const Model& model, const sim::CarrySource& from,
                        const std::vector<Eigen::Vector3d>& path, const Eigen::Vector3d& direction,
                        double depth_mm);

/// The quick half, between two steps: the prepared simulation continues `sim` (its state of
/// this moment carried to the copies, sim::carried_state; the material and options set again
/// when `parameters_changed` since the cut was prepared), `tools` carried (carry_tools()), the
/// report's structures placed where the organ is now, and `model` and `sim` replaced by the cut
/// ones. `prepared` is emptied. Nothing changes when it divided nothing.
/// @return the simulation it replaced (what an undo goes back to), or nothing
std::optional<sim::Simulation> take_cut(std::shared_ptr<const Model>& model, sim::Simulation& sim,
                                        ToolDriver& tools, PreparedCut& prepared,
                                        bool parameters_changed);

}  // namespace lamina::interact
