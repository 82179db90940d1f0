// The real-time loop's cuts and their undo (realtime_loop.h): a cut made on another thread while
// the loop steps on, taken in between two steps with everything that names the nodes carried to
// the cut model; the last cuts kept to be taken back.
#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <numeric>

#include "lamina/core/clock.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/interact/realtime_loop.h"
#include "lamina/interact/scalpel.h"
#include "lamina/sim/carry_over.h"

namespace lamina::interact {

void RealtimeLoop::cut(std::vector<Eigen::Vector3d> path, const Eigen::Vector3d& direction,
                       double depth_mm) {
  const Scalpel check{.path = path, .depth_direction = direction, .depth_mm = depth_mm};
  if (const auto problem = scalpel_problem(check))
    throw invalid_input("cut: " + problem->first, problem->second);
  std::lock_guard lock(mutex_);
  new_cut_ = CutRequest{std::move(path), direction, depth_mm};
  wake_.notify_all();
}

void RealtimeLoop::undo_cut() {
  std::lock_guard lock(mutex_);
  ++new_undos_;
  wake_.notify_all();
}

// The undo, on the stepping thread: everything the last cut changed put back (the shape and the
// motion as they were just before it); the clock runs on.
void RealtimeLoop::apply_undo() {
  if (cut_job_.valid()) return;  // after the cut being made, which it may be asked to undo
  for (; undos_ > 0; --undos_) {
    if (undo_.empty()) {
      cut_error_ = "undo: there is no cut to undo";
      log::warn("{}", cut_error_);
      undos_ = 0;
      return;
    }
    // The organ as it was just before the cut, on the clock of now and with the parameters of
    // now (a material, solver or dt set since the cut is kept, as the world's undo keeps it).
    BeforeCut& b = undo_.back();
    const double time_s = sim_.time_s;
    const int64_t steps = sim_.steps;
    const sim::Material material = sim_.material();
    const sim::SolverOptions solver = sim_.options();
    const RoutingOptions routing = tools_.routing;
    model_ = std::move(b.model);
    sim_ = std::move(b.sim);
    sim_.time_s = time_s, sim_.steps = steps;
    if (b.params_version != params_version_) sim::set_parameters(sim_, material, solver);
    forces_ = std::move(b.forces);
    tools_ = std::move(b.tools);
    tools_.routing = routing;
    undo_.pop_back();
    tools_.tip = {};
    proxy_ = {};
    tip_contact_ = -1;
    ++model_version_;
    --cuts_;
    last_cut_ = {};
    cut_error_.clear();
    log::info("undo: the last cut taken back ({} cut(s) in force)", cuts_);
    publish(true);
  }
}

// A cut: begun on another thread (the model divided, a simulation of the cut model made and
// its solver prepared, from copies of what it needs: tens to hundreds of milliseconds) while the
// loop steps on, then taken in between two steps (take_cut()). One at a time: a cut asked for
// meanwhile waits for it, and so does an undo. Without the thread (run_steps()) it is waited for.
void RealtimeLoop::apply_cut() {
  take_cut(/*wait=*/false);
  if (!cut_ || cut_job_.valid()) return;
  const double t0 = now_s();
  const CutRequest c = std::move(*cut_);
  cut_.reset();
  const std::shared_ptr<const Model> before = model_;
  // The model the loop was made with is the caller's, who may change it once a cut model is
  // published (the viewer shows the cut model in its place): the first cut takes a copy for the
  // loop to own (the model an undo goes back to).
  const bool owned = model_.use_count() != 0;
  auto from = std::make_shared<const sim::CarrySource>(sim::carry_source(sim_));
  cut_params_version_ = params_version_;
  cut_job_ = std::async(std::launch::async, [before, owned, from, c] {
    omp_set_num_threads(1);  // the stepping thread keeps the other core
    CutJob j;
    try {
      const Model* base = before.get();
      if (!owned) {
        j.own = std::make_shared<const Model>(*before);
        std::vector<int32_t> same(static_cast<size_t>(before->node_count()));
        std::iota(same.begin(), same.end(), 0);
        j.own_sim = sim::made_for_cut(*from, *before, *j.own, same, /*prepare=*/false);
        base = j.own.get();
      }
      j.cut = prepare_cut(*base, *from, c.path, c.direction, c.depth_mm);
    } catch (const Error& e) {
      j.error = e.what();
    }
    return j;
  });
  if (thread_.joinable() && options_.background_cuts) {  // the steps meanwhile: one thread
                                                         // fewer, the job has its core
    stepping_threads_ = omp_get_max_threads();
    if (stepping_threads_ > 1 && omp_get_num_procs() <= stepping_threads_)
      omp_set_num_threads(stepping_threads_ - 1);
    longest_cut_pause_us_ = std::max(longest_cut_pause_us_, 1e6 * (now_s() - t0));
  } else {
    take_cut(/*wait=*/true);
    if (thread_.joinable())
      longest_cut_pause_us_ = std::max(longest_cut_pause_us_, 1e6 * (now_s() - t0));
  }
}

// The cut made on the other thread, taken in between two steps: the state of this moment put
// into the cut model's simulation (sim::carried_state), the tools' nodes moved to the copies
// (carry_tools()), the tip's proxy started afresh on the cut shape.
void RealtimeLoop::take_cut(bool wait) {
  if (!cut_job_.valid()) return;
  if (!wait && cut_job_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;
  const double t0 = now_s();
  CutJob j = cut_job_.get();
  if (stepping_threads_ > 0) omp_set_num_threads(stepping_threads_);
  stepping_threads_ = 0;
  if (!j.error.empty()) {
    cut_error_ = j.error;
    log::warn("{}", cut_error_);
    publish(true);
    return;
  }
  try {
    if (j.own) {  // from now on the loop's own copy of the model, the same state on it
      sim::restore_state(*j.own_sim, sim::capture_state(sim_));
      sim_ = std::move(*j.own_sim);
      model_ = std::move(j.own);
    }
    cut_error_.clear();
    if (j.cut.cut) {
      // Everything that names the nodes carried to the copies (a live force by its node, as a
      // tool by vertex is: the node's first copy, on the skin as it was); what an undo goes back
      // to kept: the simulation itself, moved (a copy took 5-6 ms at paper size, a step's time
      // five times over). A force on no node of the organ (route_forces() skips it) stays.
      const std::vector<LiveForce> forces_before = forces_;
      ToolDriver tools_before = tools_;
      std::shared_ptr<const Model> model_before = model_;
      const auto on_organ = [&](const LiveForce& f) {
        return f.node >= 0 && f.node < model_->node_count();
      };
      for (const LiveForce& f : forces_)
        if (on_organ(f)) tools_.tools.push_back(Tool{.vertex = f.node});
      std::optional<sim::Simulation> sim_before =
          interact::take_cut(model_, sim_, tools_, j.cut, params_version_ != cut_params_version_);
      for (size_t k = 0, t = 0; k < forces_.size(); ++k)
        if (on_organ(forces_before[k])) forces_[k].node = tools_.tools[t++].vertex;
      tools_.tools.clear();
      if (undo_.size() == static_cast<size_t>(kUndoDepth)) undo_.erase(undo_.begin());
      undo_.push_back({std::move(model_before), std::move(*sim_before), forces_before,
                       std::move(tools_before), params_version_});
      tools_.tip = {};
      proxy_ = {};
      tip_contact_ = -1;
      ++model_version_;
      ++cuts_;
      for (const model::StructureCut& x : j.cut.report.structures_cut)
        log::warn("cut: {} cut across at ({:.1f}, {:.1f}, {:.1f}) mm, {:.1f} mm wide", x.name,
                  x.position_mm.x(), x.position_mm.y(), x.position_mm.z(), x.diameter_mm);
    }
    last_cut_ = j.cut.report;
  } catch (const Error& e) {
    tools_.tools.clear();  // the forces' stand-ins, if the cut failed while they were in
    cut_error_ = e.what();
    log::warn("{}", cut_error_);
  }
  if (!wait) longest_cut_pause_us_ = std::max(longest_cut_pause_us_, 1e6 * (now_s() - t0));
  publish(true);
}

}  // namespace lamina::interact
