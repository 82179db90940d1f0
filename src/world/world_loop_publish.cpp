// The world loop's snapshots (world_loop.h): what a caller copies when it draws.
#include <algorithm>

#include "lamina/world/world_loop.h"
#include "world_loop_impl.h"

namespace lamina::world {

bool WorldLoop::latest(WorldSnapshot& out) const {
  std::lock_guard lock(impl_->snapshot_mutex);
  if (impl_->published.generation <= out.generation && !out.bodies.empty()) return false;
  out = impl_->published;
  return true;
}

interact::ReactionSample WorldLoop::latest_reaction() const {
  std::lock_guard lock(impl_->reaction_mutex);
  return impl_->reaction;
}

interact::ReactionSample WorldLoop::latest_reaction(BodyId id) const {
  const Impl& m = *impl_;
  std::lock_guard lock(m.reaction_mutex);
  interact::ReactionSample out = m.reaction;
  const auto slot = static_cast<size_t>(id.index);
  // A loop makes and destroys no body: a slot's generation is written by nobody meanwhile.
  const bool live = id.index >= 0 && slot < m.world.bodies.size() &&
                    m.world.bodies[slot].generation == id.generation;
  out.reaction_mn = live ? m.tools_reaction[slot] : Eigen::Vector3d::Zero();
  return out;
}

void WorldLoop::Impl::publish(bool force) {
  const double t = now_s();
  if (!force && t - last_publish_s < options.publish_interval_s) return;
  last_publish_s = t;

  std::unique_lock lock(snapshot_mutex, std::defer_lock);
  lock_waits.acquire(lock);
  WorldSnapshot& s = published;
  size_t n = 0;
  for (size_t slot = 0; slot < world.bodies.size(); ++slot) {
    const BodySlot& bs = world.bodies[slot];
    if (!bs.alive) continue;
    if (s.bodies.size() <= n) s.bodies.emplace_back();
    BodyView& v = s.bodies[n];
    const Body& b = bs.body;
    v.id = {static_cast<int32_t>(slot), bs.generation};
    v.name = b.name;
    v.model = b.model;
    v.topology = b.topology;
    v.x = b.sim.x;
    v.stats = n < stats.bodies.size() ? stats.bodies[n] : BodyStepStats{};
    v.material = b.sim.material();
    v.solver = b.sim.options();
    v.routing = b.tools.routing;
    // The nodes the live forces are on (carried through a cut: what a caller's follow), not
    // their routes' marker nodes, which a display skin's nearest corner may move.
    v.force_nodes.clear();
    if (slot < live.size())
      for (const interact::LiveForce& f : live[slot].forces) v.force_nodes.push_back(f.node);
    v.grasped_nodes = b.tools.hand.nodes;
    v.hands_reaction_mn =
        slot < body_reaction_mn.size() ? body_reaction_mn[slot] : Eigen::Vector3d::Zero();
    v.reaction_mn = tools_reaction[slot];
    v.contact_nodes.clear();
    for (const interact::ForceRoute& r : b.tools.live_routes)
      v.contact_nodes.push_back(r.contact_node);
    v.tip_touching = tip_contact[slot] >= 0;
    if (v.tip_touching) v.contact_nodes.push_back(tip_contact[slot]);
    v.fixed = b.sim.fixed();
    v.recoveries = b.sim.recoveries;
    v.multigrid = sim::uses_multigrid(b.sim);
    ++n;
  }
  s.bodies.resize(n);
  s.ties.clear();
  for (const AttachmentSlot& a : world.attachments)
    if (a.alive)
      for (const Tie& tie : a.attachment.ties)
        if (tie.active()) {
          const auto [p, q] = tie_ends(world, tie);
          s.ties.push_back({p, q, tie.force_mn});
        }
  s.tie_count = count_ties(world);
  s.profile = stats.profile;
  s.step_us = stats.step_us;
  s.time_s = world.time_s;
  s.steps = world.steps;
  for (const BodySlot& bs : world.bodies)
    if (bs.alive) s.dt_s = bs.body.sim.options().dt_s;
  s.rate = window;
  s.paused = stepping_paused;
  s.converged = stats.converged;
  s.unstable = unstable;
  s.unstable_body = unstable_body;
  s.ties_divided_by_strokes = strokes_divided;
  s.cuts = cuts;
  s.tets_cut = tets_cut;
  s.last_cut_ms = last_cut_ms;
  s.longest_cut_ms = longest_cut_ms;
  s.last_cut_made_ms = last_cut_made_ms;
  s.last_cut_steps_meanwhile = last_cut_steps_meanwhile;
  s.cut_message = cut_message;
  if (s.cut_events != cut_events) {  // copied once a cut, not with every snapshot
    s.last_cut = last_cut;
    s.cut_events = cut_events;
  }
  s.undoable = static_cast<int32_t>(history.undo.size());
  s.hands_reaction_mn = hands_reaction_mn();
  s.tip_touching = false;
  for (const BodySlot& bs : world.bodies)
    s.tip_touching = s.tip_touching || (bs.alive && !bs.body.tools.tip.nodes.empty());
  const interact::Grasp* g = held();
  s.grasped_body = g ? world.bodies[static_cast<size_t>(grasp_slot)].body.name : std::string();
  s.grasped_nodes = g ? static_cast<int32_t>(g->nodes.size()) : 0;
  s.lock_waits = lock_waits.count;
  s.longest_lock_wait_us = lock_waits.longest_us;
  ++s.generation;
}

}  // namespace lamina::world
