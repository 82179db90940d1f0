// One world step, in named and timed stages: each body's tools; contact and the attachments'
// ties as springs inside the bodies' implicit steps (couplings.cpp); each body's solve; the
// springs' forces measured.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>

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
  for (const BodySlot& s : world.bodies)
    if (s.alive) dt = s.body.sim.options().dt_s;
  // Bodies side by side, each on a thread of its own, the largest first: within each, its own
  // parallel regions then run on that thread alone (nested regions are inactive). Bodies of a
  // few thousand nodes gain nothing from two threads each (their regions cost more than they
  // share), and one organ's solve is most of a world's step. One body steps as it would alone.
  std::vector<int32_t>& order = world.work().solve_order;
  order.clear();
  for (size_t s = 0; s < world.bodies.size(); ++s)
    if (world.bodies[s].alive) order.push_back(static_cast<int32_t>(s));
  std::stable_sort(order.begin(), order.end(), [&](int32_t a, int32_t b) {
    return world.bodies[static_cast<size_t>(a)].body.model->node_count() >
           world.bodies[static_cast<size_t>(b)].body.model->node_count();
  });
  const auto solve = [&](int32_t s) {
    Body& b = world.bodies[static_cast<size_t>(s)].body;
    out.bodies[static_cast<size_t>(row_of_slot[static_cast<size_t>(s)])].sim = sim::step(b.sim);
  };
  const auto bodies = static_cast<int>(order.size());
  if (bodies >= 2 && omp_get_max_threads() > 1) {
    // An exception may not leave a parallel region: the first is kept and thrown after it.
    std::exception_ptr failed;
#pragma omp parallel for schedule(dynamic, 1) num_threads(std::min(bodies, omp_get_max_threads()))
    for (int k = 0; k < bodies; ++k) {
      try {
        solve(order[static_cast<size_t>(k)]);
      } catch (...) {
#pragma omp critical(lamina_world_solve)
        if (!failed) failed = std::current_exception();
      }
    }
    if (failed) std::rethrow_exception(failed);
  } else {
    for (const int32_t s : order) solve(s);
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
