// The world's real-time loop (world_loop.h): the callers' commands, checked on their threads and
// taken between two steps; the stepping thread, paced by the wall clock. Its snapshots are in
// world_loop_publish.cpp.
#include "lamina/world/world_loop.h"

#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "lamina/core/error.h"
#include "lamina/core/keep_freed_memory.h"
#include "lamina/core/log.h"
#include "lamina/interact/pacer.h"
#include "world_loop_impl.h"

namespace lamina::world {

std::optional<std::vector<int32_t>> carried_force_nodes(
    const BodyView& now, const std::vector<interact::LiveForce>& sent) {
  if (now.force_nodes.size() != sent.size()) return std::nullopt;
  return now.force_nodes;
}

WorldLoop::WorldLoop(World world, WorldLoopOptions options)
    : impl_(std::make_unique<Impl>(std::move(world), std::move(options))) {
  Impl& m = *impl_;
  if (body_ids(m.world).empty()) throw invalid_input("world loop", "the world has no body");
  if (!(m.options.rate_hz >= 0.0 && m.options.rate_hz <= 1e6))
    throw invalid_input("world loop: rate_hz", "must be in [0, 1e6] steps per second");
  if (!(m.options.publish_interval_s >= 0.0))
    throw invalid_input("world loop: publish_interval_s", "must be >= 0 s");
  m.rate_hz = m.stepping_rate_hz = m.options.rate_hz;
  const size_t slots = m.world.bodies.size();
  m.live.resize(slots);
  m.tip_contact.assign(slots, -1);
  m.warned_inside.assign(slots, 0);
  m.parameters.assign(slots, 0);
  m.tools_reaction.assign(slots, Eigen::Vector3d::Zero());
  for (const BodyId id : body_ids(m.world)) {
    const Body& b = body(m.world, id);
    m.handles.push_back({id, b.topology, b.model->layers[0].node_count, b.model->rings.locality});
  }
  m.follow_the_clock();
  // Made here, not in the stepping thread's first step: each body's multigrid or factor at the
  // step the clock gives.
  for (const BodyId id : body_ids(m.world)) sim::prepare_solver(body(m.world, id).sim);
  m.window.restart(now_s(), m.world.time_s);
  m.publish(true);
}

WorldLoop::~WorldLoop() {
  stop();
}

void WorldLoop::start() {
  if (thread_.joinable()) return;
  // Freed memory stays in the process: a cut made on another thread frees and allocates
  // megabytes, and glibc's munmap/trim of them stalled the stepping thread's page faults for up
  // to 50 ms (BM_RealtimeLoopWhileCutting, docs/benchmarks.md; 11-24 ms without them).
  keep_freed_memory();
  {
    std::lock_guard lock(impl_->mutex);
    impl_->stop_requested = false;
  }
  thread_ = std::thread([this] { thread_main(); });
}

void WorldLoop::stop() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard lock(impl_->mutex);
    impl_->stop_requested = true;
  }
  impl_->wake.notify_all();
  thread_.join();
}

void WorldLoop::set_forces(BodyId id, uint32_t topology, std::vector<interact::LiveForce> forces) {
  Impl& m = *impl_;
  std::lock_guard lock(m.mutex);
  const Impl::Handle* h = &m.handle_of(id);
  if (topology != h->topology)
    throw invalid_input("world loop: body handle",
                        fmt::format("its nodes are of topology generation {}, the body's is {} "
                                    "now: pick them again on the latest snapshot",
                                    topology, h->topology));
  const int32_t skin = h->skin_nodes;
  for (const interact::LiveForce& f : forces) {
    if (f.node < 0 || f.node >= skin)
      throw invalid_input(
          "world loop: force",
          fmt::format("node {} is not on the body's skin (nodes 0..{})", f.node, skin - 1));
    if (!f.force_mn.allFinite() || !(f.radius_mm > 0.0 && std::isfinite(f.radius_mm)))
      throw invalid_input("world loop: force",
                          "a force and its radius must be finite (radius > 0)");
  }
  // The newest forces on a body replace any not yet taken: a caller faster than the steps
  // queues nothing (the stepping thread takes at most one list per body between two steps).
  for (Impl::NewForces& f : m.new_forces)
    if (f.slot == id.index) {
      f = {id.index, h->topology, std::move(forces)};
      return;
    }
  m.new_forces.push_back({id.index, h->topology, std::move(forces)});
}

// The handle of `id` among the live bodies, or a one-line refusal naming it stale.
const WorldLoop::Impl::Handle& WorldLoop::Impl::handle_of(BodyId id) const {
  const auto h =
      std::find_if(handles.begin(), handles.end(), [&](const Handle& e) { return e.id == id; });
  if (h == handles.end())
    throw invalid_input("world loop: body handle",
                        fmt::format("handle {} (generation {}) is stale: it names no body of this "
                                    "world (take the handles from the latest snapshot)",
                                    id.index, id.generation));
  return *h;
}

void WorldLoop::set_parameters(BodyId id, const sim::Material& material,
                               const sim::SolverOptions& solver,
                               const interact::RoutingOptions& routing, Dt dt_from) {
  Impl& m = *impl_;
  sim::check_parameters(material, solver);  // throws, naming the bad parameter
  const bool worlds_dt = dt_from == Dt::kTheWorlds;
  // In real time dt is the clock's (1 / rate); otherwise a new dt is the world's, every body's.
  // A caller that leaves dt to the world is not checked against a snapshot: a rate changed
  // between its read and this one would refuse it (the TSan handoff aborted on it, 2026-12-04).
  if (m.options.real_time && !worlds_dt) {
    double dt = 0.0;
    {
      std::lock_guard lock(m.snapshot_mutex);
      dt = m.published.dt_s;
    }
    if (solver.dt_s != dt)
      throw invalid_input("world loop: dt_s",
                          fmt::format("{:g} s, but in real time every body steps at 1 / rate, "
                                      "{:g} s now: change the rate instead",
                                      solver.dt_s, dt));
  }
  std::lock_guard lock(m.mutex);
  const Impl::Handle& h = m.handle_of(id);
  interact::check_routing(routing, h.rings_locality);
  for (Impl::NewParams& p : m.new_params)
    if (p.slot == id.index) {
      p = {id.index, material, solver, routing, worlds_dt};
      return;
    }
  m.new_params.push_back({id.index, material, solver, routing, worlds_dt});
}

void WorldLoop::undo_cut() {
  std::lock_guard lock(impl_->mutex);
  ++impl_->new_undos;
}

void WorldLoop::clear_forces() {
  std::lock_guard lock(impl_->mutex);
  impl_->new_forces.clear();
  impl_->clear_all_forces = true;
}

void WorldLoop::dissect(std::vector<Eigen::Vector3d> path, const Eigen::Vector3d& direction,
                        double depth_mm, double reach_mm) {
  check_stroke("dissection", path, direction, depth_mm, reach_mm);
  std::lock_guard lock(impl_->mutex);
  impl_->strokes.push_back({std::move(path), direction, depth_mm, reach_mm});
}

void WorldLoop::cut(std::vector<Eigen::Vector3d> path, const Eigen::Vector3d& direction,
                    double depth_mm, double reach_mm) {
  check_stroke("cut", path, direction, depth_mm, reach_mm);
  std::lock_guard lock(impl_->mutex);
  impl_->strokes.push_back({std::move(path), direction, depth_mm, reach_mm, true});
}

void WorldLoop::set_rate(double rate_hz) {
  std::lock_guard lock(impl_->mutex);
  impl_->rate_hz = std::clamp(std::isfinite(rate_hz) ? rate_hz : 0.0, 0.0, 1e6);
}

void WorldLoop::set_paused(bool paused) {
  {
    std::lock_guard lock(impl_->mutex);
    impl_->paused = paused;
  }
  impl_->wake.notify_all();
}

void WorldLoop::reset() {
  std::lock_guard lock(impl_->mutex);
  impl_->reset_requested = true;
}

std::vector<std::pair<BodyId, uint32_t>> WorldLoop::bodies() const {
  std::lock_guard lock(impl_->mutex);
  std::vector<std::pair<BodyId, uint32_t>> out;
  for (const Impl::Handle& h : impl_->handles) out.emplace_back(h.id, h.topology);
  return out;
}

void WorldLoop::run_steps(int64_t steps) {
  if (thread_.joinable()) throw Error(ErrorKind::kInternal, "run_steps() while the loop runs");
  Impl& m = *impl_;
  {
    std::lock_guard lock(m.mutex);
    m.apply_pending();
  }
  m.apply_cuts();
  for (int64_t k = 0; k < steps && !m.halted(); ++k) m.one_step();
  m.publish(true);
}

void WorldLoop::thread_main() {
  Impl& m = *impl_;
  if (m.options.threads > 0) omp_set_num_threads(m.options.threads);
  m.threaded = true;
  interact::Pacer pacer;
  std::unique_lock lock(m.mutex);
  while (!m.stop_requested) {
    if (m.paused || m.halted()) {  // unstable: no more steps until reset()
      m.wake.wait_for(lock, std::chrono::milliseconds(20));
      m.apply_pending();
      lock.unlock();
      m.apply_cuts();
      m.publish(true);
      m.lock_waits.acquire(lock);
      pacer.restart();
      continue;
    }
    m.apply_pending();
    pacer.set_rate(m.stepping_rate_hz);
    lock.unlock();
    m.apply_cuts();
    m.late_us = pacer.lateness_us();
    m.one_step();
    m.publish(false);
    m.lock_waits.acquire(lock);
    const interact::Pacer::Clock::time_point tick = pacer.advance();
    if (pacer.paced()) m.wake.wait_until(lock, tick, [&m] { return m.stop_requested; });
  }
  m.threaded = false;  // run_steps() after stop() cuts on the caller's thread
}

// ---- the stepping thread's side (Impl) ----------------------------------------------------

void WorldLoop::Impl::follow_the_clock() {
  if (!options.real_time || !(stepping_rate_hz > 0.0)) return;
  const double dt = 1.0 / stepping_rate_hz;
  for (const BodyId id : body_ids(world)) {
    sim::Simulation& s = body(world, id).sim;
    if (s.options().dt_s == dt) continue;
    sim::SolverOptions o = s.options();
    o.dt_s = dt;
    sim::set_parameters(s, s.material(), o);
    ++parameters[static_cast<size_t>(id.index)];
  }
}

void WorldLoop::Impl::apply_pending() {
  stepping_paused = paused;
  std::vector<int32_t> reroute;
  if (reset_requested) {
    // The grasper opens and the caller's jaws count as open (a hand still gripping closes them
    // again); then the bodies cut since go back uncut (renumbered again: their live forces go).
    open_grasper();
    jaws.reset();
    close_at.reset();
    new_close.reset();
    new_jaws.reset();
    jaws_closed = false;
    undos = new_undos = 0;
    std::vector<int32_t> put_back_slots;
    put_back_all(world, history, &put_back_slots);
    for (const int32_t slot : put_back_slots) topology_changed(slot);
    tissue_cuts.clear();
    ++resets;  // a cut being made of the bodies as they were is dropped when done
    cuts = 0;
    tets_cut = 0;
    last_cut_ms = 0.0;
    last_cut_made_ms = 0.0;
    last_cut_steps_meanwhile = 0;
    cut_message.clear();
    last_cut.clear();
    ++cut_events;
    world::reset(world);
    unstable = sim::Instability::kNone;
    unstable_body.clear();
    strokes_divided = 0;
    window.restart_sim(world.time_s);
    reset_requested = false;
    for (size_t k = 0; k < live.size(); ++k) {
      reroute.push_back(static_cast<int32_t>(k));
      forget_tip(static_cast<int32_t>(k));  // the tip's proxies placed afresh on the rest shape
    }
  }
  if (rate_hz != stepping_rate_hz) {
    stepping_rate_hz = rate_hz;
    window.restart(now_s(), world.time_s);  // a new rate is judged on its own steps
    follow_the_clock();
  }
  if (clear_all_forces) {
    for (size_t k = 0; k < live.size(); ++k) {
      live[k].forces.clear();
      reroute.push_back(static_cast<int32_t>(k));
    }
    clear_all_forces = false;
  }
  for (NewForces& f : new_forces) {
    // Checked against a topology a cut has since renumbered: its nodes are not the body's now.
    if (!world.bodies[static_cast<size_t>(f.slot)].alive ||
        world.bodies[static_cast<size_t>(f.slot)].body.topology != f.topology)
      continue;
    live[static_cast<size_t>(f.slot)].forces = std::move(f.forces);
    reroute.push_back(f.slot);
  }
  new_forces.clear();
  undos += new_undos;
  new_undos = 0;
  for (const NewParams& p : new_params) reroute.push_back(p.slot);
  apply_parameters();
  take_hands();
  for (Stroke& s : strokes) {
    if (s.cuts_tissue)
      tissue_cuts.push_back(std::move(s));
    else
      strokes_divided += dissect_along(world, s.path, s.direction, s.depth_mm, s.reach_mm);
  }
  strokes.clear();
  std::sort(reroute.begin(), reroute.end());
  reroute.erase(std::unique(reroute.begin(), reroute.end()), reroute.end());
  for (const int32_t slot : reroute) route_forces(slot);
}

// New parameters for the bodies (set_parameters(), checked there), each body's newest. In real
// time dt stays the clock's (follow_the_clock() may have changed it since the check), and so
// does the world's when the caller left it (Dt::kTheWorlds); otherwise a new dt is every body's.
void WorldLoop::Impl::apply_parameters() {
  for (NewParams& p : new_params) {
    BodySlot& bs = world.bodies[static_cast<size_t>(p.slot)];
    if (!bs.alive) continue;
    if (options.real_time || p.worlds_dt) p.solver.dt_s = bs.body.sim.options().dt_s;
    sim::set_parameters(bs.body.sim, p.material, p.solver);
    bs.body.tools.routing = p.routing;
    ++parameters[static_cast<size_t>(p.slot)];
    for (size_t k = 0; k < world.bodies.size(); ++k) {
      sim::Simulation& other = world.bodies[k].body.sim;
      if (!world.bodies[k].alive || other.options().dt_s == p.solver.dt_s) continue;
      sim::SolverOptions o = other.options();
      o.dt_s = p.solver.dt_s;
      sim::set_parameters(other, other.material(), o);
      ++parameters[k];
    }
  }
  new_params.clear();
}

// A body's live forces routed on its shape of the moment (as the one-organ loop routes them:
// when they change, not every step) into its tools' live routes.
void WorldLoop::Impl::route_forces(int32_t slot) {
  BodySlot& bs = world.bodies[static_cast<size_t>(slot)];
  if (!bs.alive) return;
  Body& b = bs.body;
  Live& l = live[static_cast<size_t>(slot)];
  std::vector<interact::ForceRoute>& routes = b.tools.live_routes;
  routes.clear();
  for (const interact::LiveForce& f : l.forces) {
    routes.push_back(interact::load_at_node(*b.model, b.sim.x, f.node, f.force_mn, f.radius_mm,
                                            b.tools.routing));
    if (b.sim.options().mode == sim::Mode::kLocal)
      b.tools.touched.insert(b.tools.touched.end(), routes.back().nodes.begin(),
                             routes.back().nodes.end());
  }
  if (b.sim.options().mode == sim::Mode::kLocal)
    interact::keep_touched_movable(b.sim, b.tools.touched);
}

// A body renumbered (cut, or put back uncut): callers' node numbers of it are checked against
// its new generation. A cut carries its live forces to their nodes' first copies (on the skin,
// as the nodes were; their routes were carried with its tools, each copy taking its share), as
// the one-organ loop carries them: a drag goes on through the cut. Put back (an undo, a reset),
// they are released: their nodes may be copies that are no longer there (an undo then sets them
// again on the nodes the copies came from: apply_undos).
void WorldLoop::Impl::topology_changed(int32_t slot, const std::vector<int32_t>* origin) {
  Body& b = world.bodies[static_cast<size_t>(slot)].body;
  for (Handle& h : handles)
    if (h.id.index == slot) {
      h.topology = b.topology;
      h.skin_nodes = b.model->layers[0].node_count;
      h.rings_locality = b.model->rings.locality;
    }
  std::vector<interact::LiveForce>& forces = live[static_cast<size_t>(slot)].forces;
  if (origin != nullptr) {
    int32_t before = 0;
    for (const int32_t o : *origin) before = std::max(before, o + 1);
    const std::vector<int32_t> first = first_copies(*origin, before);
    for (interact::LiveForce& f : forces)
      f.node = f.node >= 0 && f.node < before ? first[static_cast<size_t>(f.node)] : -1;
    // Every node has a copy; a force that found none goes, and the rest are routed again.
    if (std::erase_if(forces, [](const interact::LiveForce& f) { return f.node < 0; }) > 0)
      route_forces(slot);
  } else {
    forces.clear();
    b.tools.live_routes.clear();
  }
  forget_tip(slot);
}

void WorldLoop::Impl::one_step() {
  const double t0 = now_s();
  const double from = world.time_s;
  double dt = 0.0;
  for (const BodySlot& bs : world.bodies)
    if (bs.alive) dt = bs.body.sim.options().dt_s;
  advance_dissections(options.dissections, world, from, from + dt);
  move_hands();
  step(world, stats);
  if (stats.unstable != sim::Instability::kNone) {
    unstable = stats.unstable;
    unstable_body = stats.unstable_body;
    log::error("world: body '{}' unstable at t = {:.3f} s ({}); stepping stops until a reset",
               unstable_body, world.time_s, sim::describe(unstable));
  }
  {
    // Every body's push on its live tools, as the one-organ loop renders it; an unstable step's
    // is no force to render on a haptic device: none at all.
    std::lock_guard lock(reaction_mutex);
    reaction = {hands_reaction_mn(), world.steps, world.time_s};
    for (size_t slot = 0; slot < world.bodies.size(); ++slot) {
      const BodySlot& bs = world.bodies[slot];
      const interact::HapticProxy* proxy = slot < tip_proxies.size() ? &tip_proxies[slot] : nullptr;
      tools_reaction[slot] =
          bs.alive && !halted() && proxy != nullptr
              ? interact::live_reaction(bs.body.sim, bs.body.tools, proxy->device_force_mn)
              : Eigen::Vector3d::Zero();
    }
  }
  const double t1 = now_s();
  window.add(1e6 * (t1 - t0), late_us, t1, world.time_s, stepping_rate_hz, options.real_time);
}

}  // namespace lamina::world
