// The world loop's hands (world_loop.h): the tool tip a haptic device or a headset controller
// drives, pushing every body it touches through that body's own haptic proxy, and the grasper,
// whose jaws close on the body nearest them and hold its skin until opened. The callers' side
// checks and queues; the stepping thread's moves them before each step.
#include <fmt/format.h>

#include <limits>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/interact/grasp.h"
#include "world_loop_impl.h"

namespace lamina::world {

void WorldLoop::set_tool_tip(const interact::ToolTip& tip) {
  if (const auto p = interact::tip_problem(tip))
    throw invalid_input("tool tip: " + p->key, p->problem);
  std::lock_guard lock(impl_->mutex);
  impl_->new_tip = tip;
}

void WorldLoop::set_grasper(const std::optional<interact::Jaws>& jaws) {
  if (jaws) {
    if (!(jaws->radius_mm > 0.0 && std::isfinite(jaws->radius_mm)))
      throw invalid_input("grasper: radius_mm", "must be > 0 mm");
    if (!jaws->center_mm.allFinite())
      throw invalid_input("grasper", "the jaws' position is not finite");
  }
  Impl& m = *impl_;
  std::lock_guard lock(m.mutex);
  if (m.close_failed) {  // the loop could not close them (logged): these jaws close anew
    m.jaws_closed = false;
    m.close_failed = false;
  }
  if (jaws && !m.jaws_closed) {
    // Closing: some body's skin must be under the jaws now (they close on the next step's
    // shape; if it has moved away by then, one line is logged and they stay open).
    bool any = false;
    {
      std::lock_guard snap(m.snapshot_mutex);
      for (const BodyView& b : m.published.bodies)
        any = any || interact::anything_under_jaws(*b.model, b.x, *jaws, &b.fixed);
    }
    if (!any)
      throw invalid_input("grasper", fmt::format("nothing under the jaws: no body's free skin "
                                                 "within {} mm of [{:.1f}, {:.1f}, {:.1f}] (none "
                                                 "there, or it is fixed)",
                                                 jaws->radius_mm, jaws->center_mm.x(),
                                                 jaws->center_mm.y(), jaws->center_mm.z()));
    m.new_close = *jaws;
  }
  m.jaws_closed = jaws.has_value();
  m.new_jaws = jaws;
}

void WorldLoop::Impl::take_hands() {
  if (new_tip) {
    tip = *new_tip;
    new_tip.reset();
  }
  if (new_close) {  // closed anew: whatever the jaws held before (an open not seen) goes
    open_grasper();
    close_at = *new_close;
    new_close.reset();
  }
  if (new_jaws) {
    jaws = *new_jaws;
    new_jaws.reset();
  }
}

Eigen::Vector3d WorldLoop::Impl::hands_reaction_mn() const {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& f : body_reaction_mn) sum += f;
  return sum;
}

void WorldLoop::Impl::move_hands() {
  tip_proxies.resize(world.bodies.size());
  body_reaction_mn.assign(world.bodies.size(), Eigen::Vector3d::Zero());
  for (size_t slot = 0; slot < world.bodies.size(); ++slot) {
    BodySlot& bs = world.bodies[slot];
    if (!bs.alive) continue;
    Body& b = bs.body;
    interact::HapticProxy& proxy = tip_proxies[slot];
    if (!tip.active) {
      if (!b.tools.tip.nodes.empty()) b.tools.tip = {};
      proxy = {};  // placed afresh when the tip comes on again
      tip_contact[slot] = -1;
      continue;
    }
    b.tools.tip = interact::load_of_tip(*b.model, b.sim.x, tip, b.tools.routing, proxy);
    body_reaction_mn[slot] += proxy.device_force_mn;
    if (proxy.started_inside && warned_inside[slot] == 0)
      log::warn(
          "tool tip: the device is inside '{}', {:.1f} mm under its skin; the tip touches it "
          "only once it is brought out (a tool starts outside the organ)",
          b.name, proxy.start_depth_mm);
    warned_inside[slot] = proxy.started_inside ? 1 : 0;
    // The paper's local mode: the tissue a new contact loads becomes movable, and stays so.
    const int32_t contact = b.tools.tip.contact_node;
    if (contact >= 0 && contact != tip_contact[slot] && b.sim.options().mode == sim::Mode::kLocal) {
      b.tools.touched.insert(b.tools.touched.end(), b.tools.tip.nodes.begin(),
                             b.tools.tip.nodes.end());
      interact::keep_touched_movable(b.sim, b.tools.touched);
    }
    tip_contact[slot] = contact;
  }
  if (!jaws) {
    open_grasper();
    close_at.reset();
    return;
  }
  if (grasp_slot < 0) {
    // The body whose free skin is nearest the jaws' centre closes on them (a fixed node cannot
    // be held: jaws on a body's fixed part close on the next body they reach, or not at all).
    const interact::Jaws& at = close_at ? *close_at : *jaws;
    double nearest = std::numeric_limits<double>::infinity();
    for (size_t slot = 0; slot < world.bodies.size(); ++slot) {
      const BodySlot& bs = world.bodies[slot];
      if (!bs.alive) continue;
      const Eigen::MatrixX3d& x = bs.body.sim.x;
      const auto& fixed = bs.body.sim.fixed();
      for (int32_t i = 0; i < bs.body.model->layers[0].node_count; ++i) {
        const double d = (x.row(i).transpose() - at.center_mm).squaredNorm();
        if (!fixed[i] && d < nearest) {
          nearest = d;
          grasp_slot = static_cast<int32_t>(slot);
        }
      }
    }
    try {
      if (grasp_slot < 0 || nearest > at.radius_mm * at.radius_mm)
        throw invalid_input(
            "grasper",
            fmt::format("nothing under the jaws: no free skin node within {} mm of "
                        "[{:.1f}, {:.1f}, {:.1f}] (the skin there is fixed, or it "
                        "moved away); they stay open",
                        at.radius_mm, at.center_mm.x(), at.center_mm.y(), at.center_mm.z()));
      interact::close_jaws(world.bodies[static_cast<size_t>(grasp_slot)].body.sim, at,
                           world.bodies[static_cast<size_t>(grasp_slot)].body.tools.hand,
                           "grasper");
    } catch (const Error& e) {
      log::warn("world: {}", e.what());
      grasp_slot = -1;
      jaws.reset();
      close_at.reset();
      std::lock_guard lock(mutex);
      close_failed = true;  // the caller's next jaws close anew
      return;
    }
    close_at.reset();
    Body& held = world.bodies[static_cast<size_t>(grasp_slot)].body;
    if (held.sim.options().mode == sim::Mode::kLocal) {  // the tissue around the jaws moves
      held.tools.touched.insert(held.tools.touched.end(), held.tools.hand.nodes.begin(),
                                held.tools.hand.nodes.end());
      interact::keep_touched_movable(held.sim, held.tools.touched);
    }
  }
  Body& b = world.bodies[static_cast<size_t>(grasp_slot)].body;
  interact::move_jaws(b.sim, jaws->center_mm, b.tools.hand);
  const Eigen::Vector3d pull = interact::grasp_reaction(b.sim, b.tools.hand);
  body_reaction_mn[static_cast<size_t>(grasp_slot)] += pull;
}

void WorldLoop::Impl::open_grasper() {
  if (grasp_slot >= 0) {
    BodySlot& bs = world.bodies[static_cast<size_t>(grasp_slot)];
    if (bs.alive && !bs.body.tools.hand.nodes.empty())
      interact::open_jaws(bs.body.sim, bs.body.tools.hand);
    if (bs.alive) bs.body.tools.hand = {};
  }
  grasp_slot = -1;
}

// A body renumbered: the tip's load on it and its proxy start over on the new shape.
void WorldLoop::Impl::forget_tip(int32_t slot) {
  if (static_cast<size_t>(slot) < tip_proxies.size()) tip_proxies[static_cast<size_t>(slot)] = {};
  tip_contact[static_cast<size_t>(slot)] = -1;
  BodySlot& bs = world.bodies[static_cast<size_t>(slot)];
  if (bs.alive) bs.body.tools.tip = {};
}

const interact::Grasp* WorldLoop::Impl::held() const {
  if (grasp_slot < 0) return nullptr;
  const BodySlot& bs = world.bodies[static_cast<size_t>(grasp_slot)];
  return bs.alive && !bs.body.tools.hand.nodes.empty() ? &bs.body.tools.hand : nullptr;
}

}  // namespace lamina::world
