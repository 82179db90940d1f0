#pragma once
/// \file
/// A grasper: when its jaws close, the skin nodes under them attach to it and follow it,
/// rigidly (sim::hold_nodes: the stiff-spring limit, kept inside the implicit step, so a
/// retraction is as stable as the tissue), until it opens. The force on the grasper is the
/// attachments' sum: the tissue's pull on the held nodes.

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "lamina/sim/simulation.h"

namespace lamina::interact {

/// The jaws: where they close, and how far from that point skin is taken.
struct Jaws {
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();
  double radius_mm = 4.0;  ///< skin nodes within this distance when the jaws close are held
};

/// What a closed grasper holds.
struct Grasp {
  std::vector<int32_t> nodes;  ///< held skin nodes, ascending (empty: open)
  Eigen::Vector3d closed_at_mm = Eigen::Vector3d::Zero();  ///< the jaws' centre when they closed
  Eigen::MatrixX3d offsets;  ///< each node's position minus the jaws' centre when they closed
  Eigen::MatrixX3d targets;  ///< where they are held now (reused each move)
};

/// Closes the jaws at jaws.center_mm on the current positions: every free skin node within
/// jaws.radius_mm is held where it is. `what` names the tool in errors.
/// \note Throws lamina::Error (kInvalidInput) when no free skin node is under the jaws (naming
///   the point and the radius), or for a radius that is not a positive number; nothing is held.
void close_jaws(sim::Simulation& sim, const Jaws& jaws, Grasp& grasp, const std::string& what);

/// Whether any skin node at positions x lies within jaws.radius_mm of jaws.center_mm: the check
/// made before jaws are asked to close (a scene at rest, the loops' callers), where close_jaws()
/// itself will run later, on another shape.
/// @param fixed  if given, per node 1 = held where it is: only the others count, as close_jaws()
///               holds only free nodes (the loops' published flags)
bool anything_under_jaws(const Model& model, const Eigen::MatrixX3d& x, const Jaws& jaws,
                         const std::vector<uint8_t>* fixed = nullptr);

/// Moves the held nodes with the jaws' centre (their offsets kept). Cheap every step: the
/// nodes are held already (sim::hold_nodes moves them and refreshes only their positions).
void move_jaws(sim::Simulation& sim, const Eigen::Vector3d& center_mm, Grasp& grasp);

/// Opens the jaws: the held nodes move again.
void open_jaws(sim::Simulation& sim, Grasp& grasp);

/// The force on the grasper, mN: the tissue's pull on the held nodes (sim::internal_force_on).
Eigen::Vector3d grasp_reaction(const sim::Simulation& sim, const Grasp& grasp);

}  // namespace lamina::interact
