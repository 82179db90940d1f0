// The real-time loop's publications (realtime_loop.h): the snapshot a caller copies when it
// draws and the reaction a haptic device reads every step.
#include <algorithm>

#include "lamina/core/clock.h"
#include "lamina/interact/realtime_loop.h"
#include "lamina/sim/simulation.h"

namespace lamina::interact {

ReactionSample RealtimeLoop::latest_reaction() const {
  std::lock_guard lock(reaction_mutex_);
  return reaction_;
}

void RealtimeLoop::publish(bool force) {
  const double t = now_s();
  if (!force && t - last_publish_s_ < options_.publish_interval_s) return;
  last_publish_s_ = t;

  // The last step's reaction (one_step computes it for latest_reaction()), not a second pass.
  const Eigen::Vector3d reaction = latest_reaction().reaction_mn;

  std::unique_lock lock(snapshot_mutex_, std::defer_lock);
  acquire(lock);
  LoopSnapshot& s = published_;
  s.x = sim_.x;
  s.stats = last_stats_;
  s.time_s = sim_.time_s;
  s.steps = sim_.steps;
  s.recoveries = sim_.recoveries;
  s.achieved_rate_hz = window_.achieved_rate_hz;
  s.measured_rate_hz = window_.measured_rate_hz;
  s.dt_s = sim_.options().dt_s;
  s.material = sim_.material();
  s.solver = sim_.options();
  s.routing = tools_.routing;
  s.multigrid = sim::uses_multigrid(sim_);
  s.real_time_factor = window_.real_time_factor;
  s.keeping_up = window_.keeping_up;
  s.mean_step_us = window_.mean_step_us;
  s.worst_jitter_us = window_.worst_jitter_us;
  s.reaction_mn = reaction;
  s.contact_nodes.clear();
  for (const ForceRoute& r : tools_.live_routes) s.contact_nodes.push_back(r.contact_node);
  if (tip_contact_ >= 0) s.contact_nodes.push_back(tip_contact_);
  s.tool_tip_touching = tip_contact_ >= 0;
  s.grasped_nodes = tools_.hand.nodes;
  s.fixed = sim_.fixed();
  s.lock_waits = lock_waits_.count;
  s.longest_cut_pause_us = longest_cut_pause_us_;
  s.longest_lock_wait_us = lock_waits_.longest_us;
  s.model = model_;
  s.model_version = model_version_;
  s.cuts = cuts_;
  s.undoable = static_cast<int32_t>(undo_.size());
  s.last_cut = last_cut_;
  s.cut_error = cut_error_;
  ++s.generation;
}

void RealtimeLoop::acquire(std::unique_lock<std::mutex>& lock) {
  lock_waits_.acquire(lock);
}

}  // namespace lamina::interact
