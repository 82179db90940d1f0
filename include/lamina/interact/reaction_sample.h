#pragma once
/// \file
/// The tissue's push back on the tools after one step, as the real-time loops publish it every
/// step (world::OrganLoop::latest_reaction(), world::WorldLoop::latest_reaction()): a haptic
/// device's rate, without copying the state their snapshots copy.
#include <Eigen/Core>
#include <cstdint>

namespace lamina::interact {

struct ReactionSample {
  Eigen::Vector3d reaction_mn = Eigen::Vector3d::Zero();  ///< mN
  int64_t steps = 0;                                      ///< the step it follows
  double time_s = 0.0;                                    ///< simulated time after that step
};

}  // namespace lamina::interact
