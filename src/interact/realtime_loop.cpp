// The real-time loop (realtime_loop.h): the stepping thread, paced by the wall clock; the
// callers' commands, taken in between two steps; the tools routed and the grasper moved. Its cuts
// are in realtime_loop_cuts.cpp, its snapshots in realtime_loop_publish.cpp.
#include "lamina/interact/realtime_loop.h"

#include <fmt/format.h>
#include <malloc.h>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "lamina/core/clock.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/interact/grasp.h"
#include "lamina/interact/haptic_proxy.h"
#include "lamina/interact/pacer.h"

namespace lamina::interact {

RealtimeLoop::RealtimeLoop(sim::Simulation sim, const RoutingOptions& routing,
                           const LoopOptions& options)
    : sim_(std::move(sim)),
      tools_{.routing = routing},
      options_(options),
      rings_locality_(sim_.model().rings.locality),
      rate_hz_(options.rate_hz) {
  check_routing(tools_.routing, sim_.model().rings.locality);  // here, not in the stepping thread
  stepping_rate_hz_ = rate_hz_;
  follow_the_clock(rate_hz_);
  model_ = std::shared_ptr<const Model>(std::shared_ptr<const Model>(), &sim_.model());
  // At the step the clock gives: auto's trial, the multigrid or projective dynamics' factor are
  // made here, not in the stepping thread's first step (a 0.8 s hitch at 6,228 nodes and 60 Hz
  // in the viewer).
  sim::prepare_solver(sim_);
  window_.restart(now_s(), sim_.time_s);
  publish(true);
}

// Real time: one step is 1 / rate of simulated time, so that the simulated clock follows the
// wall clock whatever the scene's dt was (the viewer once stepped 10 ms at 1 kHz: ten simulated
// seconds per second).
void RealtimeLoop::follow_the_clock(double rate_hz) {
  if (!options_.real_time || !(rate_hz > 0.0)) return;
  const double dt = 1.0 / rate_hz;
  if (sim_.options().dt_s == dt) return;
  sim::SolverOptions o = sim_.options();
  o.dt_s = dt;
  sim::set_parameters(sim_, sim_.material(), o);
  ++params_version_;
}

RealtimeLoop::~RealtimeLoop() {
  stop();
}

void RealtimeLoop::start() {
  if (thread_.joinable()) return;
  // Freed memory stays in the process: a cut made on another thread frees and allocates
  // megabytes, and glibc's munmap/trim of them stalled the stepping thread's page faults for up
  // to 50 ms (BM_RealtimeLoopWhileCutting, docs/benchmarks.md; 11-24 ms without them).
  mallopt(M_MMAP_THRESHOLD, 256 << 20);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  {
    std::lock_guard lock(mutex_);
    stop_requested_ = false;
  }
  thread_ = std::thread([this] { thread_main(); });
}

void RealtimeLoop::stop() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard lock(mutex_);
    stop_requested_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void RealtimeLoop::set_forces(std::vector<LiveForce> forces) {
  std::lock_guard lock(mutex_);
  new_forces_ = std::move(forces);
}

void RealtimeLoop::set_tool_tip(const ToolTip& tip) {
  if (tip.active)
    if (const auto p = tip_problem(tip)) throw invalid_input("tool tip: " + p->key, p->problem);
  std::lock_guard lock(mutex_);
  new_tip_ = tip;
}

void RealtimeLoop::set_grasper(const std::optional<Jaws>& jaws) {
  if (jaws) {
    if (!(jaws->radius_mm > 0.0 && std::isfinite(jaws->radius_mm)))
      throw invalid_input("grasper: radius_mm", "must be > 0 mm");
    if (!jaws->center_mm.allFinite())
      throw invalid_input("grasper", "the jaws' position is not finite");
  }
  std::lock_guard lock(mutex_);
  if (jaws && !jaws_closed_) {
    // Closing: something must be under the jaws now (the loop closes them on the next step's
    // shape; if the skin moved away in between, it logs one line and leaves them open).
    bool any = false;
    {
      std::lock_guard snap(snapshot_mutex_);
      // The published model and shape: a cut replaces sim_ on the stepping thread.
      any = anything_under_jaws(*published_.model, published_.x, *jaws, &published_.fixed);
    }
    if (!any)
      throw invalid_input("grasper", fmt::format("nothing under the jaws: no free skin node within "
                                                 "{} mm of [{:.1f}, {:.1f}, {:.1f}] (none there, "
                                                 "or it is fixed)",
                                                 jaws->radius_mm, jaws->center_mm.x(),
                                                 jaws->center_mm.y(), jaws->center_mm.z()));
  }
  if (jaws && !jaws_closed_) new_close_ = *jaws;
  jaws_closed_ = jaws.has_value();
  new_jaws_ = jaws;
}

void RealtimeLoop::set_parameters(const sim::Material& material, const sim::SolverOptions& solver,
                                  const RoutingOptions& routing) {
  // Validate now, on the caller's thread, so that the error reaches the caller.
  check_routing(routing, rings_locality_);  // a cut keeps the rings' locality
  sim::check_parameters(material, solver);  // throws, naming the bad parameter
  std::lock_guard lock(mutex_);
  new_params_ = Params{material, solver, routing};
}

void RealtimeLoop::set_rate(double rate_hz) {
  std::lock_guard lock(mutex_);
  rate_hz_ = std::max(rate_hz, 0.0);
}

void RealtimeLoop::set_paused(bool paused) {
  {
    std::lock_guard lock(mutex_);
    paused_ = paused;
  }
  wake_.notify_all();
}

void RealtimeLoop::reset() {
  std::lock_guard lock(mutex_);
  reset_requested_ = true;
}

bool RealtimeLoop::latest(LoopSnapshot& out) const {
  std::lock_guard lock(snapshot_mutex_);
  if (published_.generation <= out.generation && out.x.rows() == published_.x.rows()) return false;
  out = published_;
  return true;
}

void RealtimeLoop::run_steps(int64_t steps) {
  if (thread_.joinable()) throw Error(ErrorKind::kInternal, "run_steps() while the loop runs");
  {
    std::lock_guard lock(mutex_);
    apply_pending();
  }
  apply_cut();
  apply_undo();
  for (int64_t k = 0; k < steps && !halted(); ++k) one_step();
  publish(true);
}

void RealtimeLoop::apply_pending() {
  bool reroute = false;
  if (reset_requested_) {
    if (!tools_.hand.nodes.empty())
      open_jaws(sim_, tools_.hand);  // rest is the organ's own, unheld
    jaws_.reset();
    close_at_.reset();
    new_close_.reset();
    new_jaws_.reset();
    jaws_closed_ = false;
    sim::reset(sim_);
    last_stats_ = {};  // an unstable simulation steps again from rest
    proxy_ = {};       // the tip's proxy is placed afresh on the rest shape
    window_.restart_sim(sim_.time_s);
    reset_requested_ = false;
    reroute = true;
  }
  if (new_params_) {
    ++params_version_;
    sim::set_parameters(sim_, new_params_->material, new_params_->solver);
    tools_.routing = new_params_->routing;
    new_params_.reset();
    reroute = true;
  }
  if (rate_hz_ != stepping_rate_hz_) {
    window_.restart(now_s(), sim_.time_s);  // a new rate is judged on its own steps
  }
  stepping_rate_hz_ = rate_hz_;
  follow_the_clock(rate_hz_);
  if (new_forces_) {
    forces_ = std::move(*new_forces_);
    new_forces_.reset();
    reroute = true;
  }
  if (new_tip_) {
    tip_ = *new_tip_;
    new_tip_.reset();
    tip_contact_ = -1;
  }
  if (new_close_) {  // closed anew: whatever the jaws held before (an open not seen) goes
    if (!tools_.hand.nodes.empty()) open_jaws(sim_, tools_.hand);
    close_at_ = *new_close_;
    new_close_.reset();
  }
  if (new_jaws_) {
    jaws_ = *new_jaws_;
    new_jaws_.reset();
  }
  if (new_cut_) {
    cut_ = std::move(new_cut_);
    new_cut_.reset();
  }
  undos_ += new_undos_;
  new_undos_ = 0;
  if (reroute) route_forces();
}

// Live forces are routed on the shape at the moment they change (as the paper routes a tool
// when it touches down), not every step: the contact and crossings of a held drag stay put.
void RealtimeLoop::route_forces() {
  const Model& m = sim_.model();
  tools_.live_routes.clear();
  for (const LiveForce& f : forces_) {
    if (f.node < 0 || f.node >= m.layers[0].node_count || !f.force_mn.allFinite()) continue;
    tools_.live_routes.push_back(
        load_at_node(m, sim_.x, f.node, f.force_mn, f.radius_mm, tools_.routing));
    tools_.touched.insert(tools_.touched.end(), tools_.live_routes.back().nodes.begin(),
                          tools_.live_routes.back().nodes.end());
  }
  keep_touched_movable(sim_, tools_.touched);
}

void RealtimeLoop::one_step() {
  const Model& m = sim_.model();
  const double t0 = now_s();
  // The tool tip: its proxy and coupling (or the paper's penalty), afresh every step.
  tools_.tip = load_of_tip(m, sim_.x, tip_, tools_.routing, proxy_);
  if (proxy_.started_inside && !warned_inside_)
    log::warn(
        "tool tip: the device is inside the organ, {:.1f} mm under the skin; the tip touches "
        "nothing until it is brought out (a tool starts outside the organ)",
        proxy_.start_depth_mm);
  warned_inside_ = proxy_.started_inside;
  if (tools_.tip.contact_node >= 0 && tools_.tip.contact_node != tip_contact_ &&
      sim_.options().mode == sim::Mode::kLocal) {
    tools_.touched.insert(tools_.touched.end(), tools_.tip.nodes.begin(), tools_.tip.nodes.end());
    keep_touched_movable(sim_, tools_.touched);
  }
  tip_contact_ = tools_.tip.contact_node;
  move_grasper();
  apply_tools(sim_, tools_);  // the live forces' routes and the tip's load into f_ext

  last_stats_ = sim::step(sim_);
  const double t1 = now_s();
  {
    // An unstable simulation's push is no force to render on a haptic device: none at all.
    // Without routing the tools feel exactly minus their load on the tissue (Newton's third
    // law, and continuous: the penalty's); the paper's copies are not a tool's load, so there
    // the tissue's push on the loaded nodes is what comes back.
    Eigen::Vector3d reaction = Eigen::Vector3d::Zero();
    if (!halted() && tools_.routing.routing == Routing::kNone) {
      for (const ForceRoute& r : tools_.live_routes) reaction -= total_force(r);
      reaction += proxy_.device_force_mn;  // the coupling's: bounded, continuous
    } else if (!halted()) {
      reaction = reaction_force(sim_, tools_.loads);
    }
    // The grasper feels the tissue's pull on what it holds, in either model.
    if (!halted() && !tools_.hand.nodes.empty()) reaction += grasp_reaction(sim_, tools_.hand);
    std::unique_lock lock(reaction_mutex_, std::defer_lock);
    acquire(lock);
    reaction_ = {reaction, sim_.steps, sim_.time_s};
  }

  window_.add(1e6 * (t1 - t0), late_us_, t1, sim_.time_s, stepping_rate_hz_, options_.real_time);
}

// The grasper's jaws where the caller last put them: closed on the current shape when they were
// open, moved with what they hold, or opened.
void RealtimeLoop::move_grasper() {
  if (!jaws_) {
    if (!tools_.hand.nodes.empty()) open_jaws(sim_, tools_.hand);
    close_at_.reset();
    return;
  }
  if (!tools_.hand.nodes.empty()) {
    move_jaws(sim_, jaws_->center_mm, tools_.hand);
    return;
  }
  try {
    close_jaws(sim_, close_at_ ? *close_at_ : *jaws_, tools_.hand, "grasper");
  } catch (const Error& e) {  // the skin moved away since set_grasper() checked: stay open
    log::warn("{}", e.what());
    jaws_.reset();
    close_at_.reset();
    return;
  }
  close_at_.reset();
  move_jaws(sim_, jaws_->center_mm, tools_.hand);  // where the caller has moved them since
  if (sim_.options().mode == sim::Mode::kLocal) {  // the tissue around the jaws moves
    tools_.touched.insert(tools_.touched.end(), tools_.hand.nodes.begin(), tools_.hand.nodes.end());
    keep_touched_movable(sim_, tools_.touched);
  }
}

void RealtimeLoop::thread_main() {
  if (options_.threads > 0) omp_set_num_threads(options_.threads);  // this thread's own setting
  Pacer pacer;
  std::unique_lock lock(mutex_);
  while (!stop_requested_) {
    if (paused_ || halted()) {  // unstable: no more steps until reset()
      wake_.wait_for(lock, std::chrono::milliseconds(20));
      apply_pending();
      lock.unlock();
      apply_cut();
      apply_undo();
      publish(true);
      acquire(lock);
      pacer.restart();
      continue;
    }
    apply_pending();
    pacer.set_rate(rate_hz_);
    lock.unlock();
    apply_cut();
    apply_undo();

    late_us_ = pacer.lateness_us();
    one_step();
    publish(false);

    acquire(lock);
    const Pacer::Clock::time_point tick = pacer.advance();
    if (pacer.paced()) wake_.wait_until(lock, tick, [this] { return stop_requested_; });
  }
}

}  // namespace lamina::interact
