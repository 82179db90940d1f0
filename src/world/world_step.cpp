// One world step, in named and timed stages: each body's tools; contact and the attachments'
// ties as springs inside the bodies' implicit steps (couplings.cpp); each body's solve; the
// springs' forces measured.
#include <algorithm>
#include <chrono>
#include <cmath>

#include "world_work.h"

namespace lamina::world {
namespace {

using Clock = std::chrono::steady_clock;

double us_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
}

}  // namespace

WorldStepStats step(World& world) {
  WorldStepStats out;
  step(world, out);
  return out;
}

void step(World& world, WorldStepStats& out) {
  const auto t_start = Clock::now();
  std::vector<int32_t>& row_of_slot = world.work().row_of_slot;
  row_of_slot.assign(world.bodies.size(), -1);
  size_t live = 0;
  for (size_t s = 0; s < world.bodies.size(); ++s)
    if (world.bodies[s].alive) row_of_slot[s] = static_cast<int32_t>(live++);
  out.bodies.resize(live);
  for (BodyStepStats& b : out.bodies) b = BodyStepStats{};
  out.profile = WorldProfile{};
  out.ties_torn = 0;
  out.unstable = sim::Instability::kNone;
  out.unstable_body.clear();
  if (live == 0) return;

  auto t0 = Clock::now();
  for (BodySlot& s : world.bodies)
    if (s.alive) interact::apply_tools(s.body.sim, s.body.tools);
  out.profile.tools_us = us_since(t0);

  // A world of one body without attachments steps exactly as its simulation alone: contact
  // within it (self-contact) is the only coupling it can have.
  const bool ties = std::any_of(world.attachments.begin(), world.attachments.end(),
                                [](const AttachmentSlot& a) { return a.alive; });
  const bool couple = ties || world.contact.enabled;
  t0 = Clock::now();
  if (couple) detail::begin_couplings(world);
  out.profile.contact_us = us_since(t0);

  t0 = Clock::now();
  double dt = 0.0;
  for (size_t s = 0; s < world.bodies.size(); ++s) {
    if (!world.bodies[s].alive) continue;
    Body& b = world.bodies[s].body;
    dt = b.sim.options().dt_s;
    out.bodies[static_cast<size_t>(row_of_slot[s])].sim = sim::step(b.sim);
  }
  out.profile.solve_us = us_since(t0);

  t0 = Clock::now();
  if (couple) detail::end_couplings(world, out);
  out.profile.contact_us += us_since(t0);

  out.converged = out.ties_torn == 0;
  for (size_t s = 0; s < world.bodies.size(); ++s) {
    if (!world.bodies[s].alive) continue;
    const sim::StepStats& st = out.bodies[static_cast<size_t>(row_of_slot[s])].sim;
    out.converged = out.converged && sim::at_rest(st);
    if (out.unstable == sim::Instability::kNone && st.unstable != sim::Instability::kNone) {
      out.unstable = st.unstable;
      out.unstable_body = world.bodies[s].body.name;
    }
  }
  world.time_s += dt;
  ++world.steps;
  out.step_us = us_since(t_start);
}

}  // namespace lamina::world
