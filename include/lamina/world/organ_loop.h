#pragma once
/// \file
/// One organ in real time: a world of one body (world_loop.h) stepping in its own thread at a
/// fixed rate (1 kHz by default, a haptic device's rate), decoupled from whoever draws it. The
/// caller sets forces and parameters at any time; they take effect between two steps. The loop
/// publishes a snapshot of the state (positions, step statistics, achieved rate, jitter, the
/// tissue's reaction force) that the caller copies when it wants to draw: double-buffered, so
/// neither side waits for the other. The viewer, serve (OpenIGTLink and the web page) and the C
/// API drive one organ through it; a scene of several bodies drives a WorldLoop itself.
///
/// The organ steps exactly as its simulation alone (no contact with itself: world::ContactOptions
/// is off), so that every figure of the one-organ loop it replaces is kept. Every public member
/// function is safe to call from any one other thread.
///
///     world::OrganLoop loop(model, sim::make_simulation(*model, material), routing);
///     loop.start();
///     world::LoopSnapshot snap;
///     while (drawing) { if (loop.latest(snap)) draw(snap); }

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "lamina/interact/grasp.h"
#include "lamina/interact/haptic_proxy.h"
#include "lamina/interact/rate_window.h"
#include "lamina/interact/reaction_sample.h"
#include "lamina/interact/tools.h"
#include "lamina/model/cut_tetrahedra.h"
#include "lamina/sim/simulation.h"
#include "lamina/world/world_loop.h"

namespace lamina::world {

struct LoopOptions {
  /// Steps per wall-clock second; 0 = as fast as possible (then at the solver's own dt).
  double rate_hz = 1000.0;
  /// Real time: each step advances the simulated clock by 1 / rate_hz, so that simulated time
  /// follows the wall clock (1 ms steps at a haptic device's 1 kHz). When the machine cannot
  /// keep up, the snapshot says so (LoopSnapshot::keeping_up): the loop never stretches dt to
  /// hide it. false: the solver's dt whatever the rate (a slow or fast motion, on purpose).
  bool real_time = true;
  /// Threads each step may use; 0 = OpenMP's default. A viewer drawing on the same cores sets
  /// 1: a thread team whose second thread waits for the renderer's time slice makes every one of
  /// a step's parallel passes wait with it (measured under Xvfb: 3.5 ms steps instead of 0.6).
  int threads = 0;
  /// Minimum wall time between two published snapshots, s (a display needs no more than its
  /// refresh rate; copying a large model every step would cost more than the step).
  double publish_interval_s = 1.0 / 240.0;
  /// Cuts are made on another thread while the loop steps on, and taken in between two steps
  /// (0.1-0.4 ms of the stepping thread's at paper size); false makes them between two steps
  /// on the stepping thread, as run_steps() does (15-20 ms there at paper size: a reference).
  bool background_cuts = true;
};

/// What the loop last published. Positions are a copy: valid for as long as the caller keeps it.
struct LoopSnapshot {
  Eigen::MatrixX3d x;  ///< #nodes by 3, mm
  sim::StepStats stats;
  double time_s = 0.0;  ///< simulated time
  int64_t steps = 0;
  int64_t recoveries = 0;
  uint64_t generation = 0;        ///< increases with each publication
  double achieved_rate_hz = 0.0;  ///< steps per wall second over the last second
  double dt_s = 0.0;              ///< the step's simulated time
  /// The parameters the organ steps with now (set_parameters(); dt follows the rate), as the
  /// world's BodyView gives them: what a panel shows is what steps.
  sim::Material material;
  sim::SolverOptions solver;
  interact::RoutingOptions routing;
  /// implicit Euler's steps take the multigrid (kMultigrid, or kAuto's choice for this dt)
  bool multigrid = false;
  /// Simulated seconds per wall second over the last second: 1 in real time, less when the
  /// machine cannot keep up (the simulation then runs in slow motion).
  double real_time_factor = 0.0;
  /// Real time was asked for and the last second ran at 95% of it or better.
  bool keeping_up = true;
  double mean_step_us = 0.0;  ///< over the last second
  /// The rate the last second's steps were asked for (a new rate's first second is not yet
  /// measured: until then this is the old one); 0 before the first second.
  double measured_rate_hz = 0.0;
  double worst_jitter_us = 0.0;  ///< worst lateness of a step's start over the last second
  Eigen::Vector3d reaction_mn = Eigen::Vector3d::Zero();  ///< tissue's push on the tools, mN
  std::vector<int32_t> contact_nodes;  ///< where each live force and the tool tip act
  /// The skin nodes the live forces are on, in the order they were set: a cut carries them to
  /// their nodes' first copies, an undo back (what a caller's drag follows through a change of
  /// model).
  std::vector<int32_t> force_nodes;
  bool tool_tip_touching = false;
  std::vector<int32_t> grasped_nodes;  ///< what the grasper holds (empty: open)
  /// Per node, 1 = held where it is (fixed, or held by a grasp): jaws close on the others only.
  std::vector<uint8_t> fixed;
  /// Since the loop was made: how many times the stepping thread found one of its locks held by
  /// a caller (setting forces, copying a snapshot) and the longest it waited for one, us. A
  /// caller holds them only to copy a few values, never while it draws or waits on a network,
  /// so a wait of more than milliseconds is a bug on any machine (the serve tests check it).
  int64_t lock_waits = 0;
  double longest_lock_wait_us = 0.0;
  /// The longest the stepping thread spent on a cut between two steps, us: copying the organ
  /// for it and taking it in once made (OrganLoop::cut()); the cut itself, tens to hundreds of
  /// milliseconds, is made while the loop steps on.
  double longest_cut_pause_us = 0.0;
  /// The model x is of: the one the loop was made with until a cut (OrganLoop::cut()) made
  /// another; model_version counts the changes of model (each cut that divided tetrahedra, each
  /// undo, each reset after cuts: 0, the loop's own; the world body's topology generation).
  std::shared_ptr<const Model> model;
  uint64_t model_version = 0;
  /// The cuts in force: how many divided tetrahedra (less those undone), the last one's report
  /// (its pieces, the structures it crossed, where they are then; empty after an undo), and why
  /// the last cut divided nothing or an undo had nothing to take back (empty if none; a bad path
  /// is refused by cut() itself). `undoable`: how many of the last cuts undo_cut() can take back.
  int64_t cuts = 0;
  int32_t undoable = 0;
  model::CutReport last_cut;
  std::string cut_error;
};

/// A snapshot's one-second window (LoopSnapshot carries its fields one by one), for
/// interact::rate_to_follow().
interact::RateWindow measured_window(const LoopSnapshot& snap);

class OrganLoop {
 public:
  /// Takes over `sim`, made on `model` (which the loop then shares: a caller may drop its own
  /// pointer). Does not start stepping.
  /// \note Throws lamina::Error (kInvalidInput) for routing interact::check_routing() refuses,
  ///   a simulation not made on `model`, or options out of range.
  OrganLoop(std::shared_ptr<const Model> model, sim::Simulation sim,
            const interact::RoutingOptions& routing, const LoopOptions& options = {});
  /// Takes over `sim`, whose model the caller keeps alive and unchanged while the loop lives
  /// (the loop holds it without owning it; an undo goes back to it).
  OrganLoop(sim::Simulation sim, const interact::RoutingOptions& routing,
            const LoopOptions& options = {});
  OrganLoop(const OrganLoop&) = delete;
  OrganLoop& operator=(const OrganLoop&) = delete;

  void start() { loop_.start(); }  ///< starts the thread (no-op if running)
  void stop() { loop_.stop(); }    ///< stops and joins the thread (no-op if stopped)
  bool running() const { return loop_.running(); }

  /// Replaces every user force (an empty list releases them all: the organ returns to rest),
  /// each on a skin node of the model of `model_version` (LoopSnapshot::model_version; by default
  /// the latest).
  /// \note Throws lamina::Error (kInvalidInput), nothing changing, for a model_version a cut,
  ///   an undo or a reset has moved past, a node that is not on the skin or a force or radius
  ///   that is not finite (radius > 0).
  void set_forces(std::vector<interact::LiveForce> forces,
                  std::optional<uint64_t> model_version = std::nullopt);
  /// The tool tip (a haptic device's sphere; `tip.active` false lifts it).
  /// \note Throws lamina::Error (kInvalidInput) for a tip interact::tip_problem() refuses.
  void set_tool_tip(const interact::ToolTip& tip) { loop_.set_tool_tip(tip); }
  /// The grasper: jaws given and open, they close on the skin under them (its free nodes within
  /// jaws.radius_mm, at that position, on the shape of the next step) and hold it; given and
  /// closed, they move there with what they hold (moves made before the loop's next step still
  /// close at the first position); nullopt opens them. The tissue's pull on the held nodes joins
  /// the reaction. Throws lamina::Error (kInvalidInput), nothing changing, for a radius or position
  /// that is not a finite positive number, or when closing with no skin node within the radius
  /// in the latest snapshot ("nothing under the jaws").
  void set_grasper(const std::optional<interact::Jaws>& jaws) { loop_.set_grasper(jaws); }
  /// New parameters, checked now (throws lamina::Error kInvalidInput, nothing changes), applied
  /// before the next step. In real time dt stays 1 / rate (solver.dt_s is not looked at).
  void set_parameters(const sim::Material& material, const sim::SolverOptions& solver,
                      const interact::RoutingOptions& routing);
  /// New rate (0 = as fast as possible). In real time the step becomes 1 / rate_hz.
  void set_rate(double rate_hz) { loop_.set_rate(rate_hz); }
  void set_paused(bool paused) { loop_.set_paused(paused); }
  /// Cuts the organ with a scalpel drawn on its current shape (the blade's upper end along
  /// `path`, reaching depth_mm along `direction`): made on another thread while the loop steps
  /// on and taken in between two steps (LoopOptions::background_cuts). The live forces and the
  /// grasper's hold carry over to the cut model, whose nodes are numbered anew
  /// (LoopSnapshot::model, model_version: a caller that names nodes takes them from the new
  /// model). Throws lamina::Error (kInvalidInput), nothing queued, for a bad path, depth or
  /// direction (model::blade_problem()).
  void cut(std::vector<Eigen::Vector3d> path, const Eigen::Vector3d& direction, double depth_mm) {
    loop_.cut(std::move(path), direction, depth_mm);
  }
  /// Takes the last cut back, between two steps: the model, the organ's shape and motion as they
  /// were just before it (the clock runs on, the parameters set since are kept); the live forces
  /// go back to the nodes their copies came from, the grasper opens. The last kUndoDepth cuts
  /// can be undone, one call each; with none, the snapshot's cut_error says so.
  void undo_cut() { loop_.undo_cut(); }
  static constexpr int kUndoDepth = WorldLoop::kUndoDepth;
  /// Puts every node back at rest with zero velocity and time 0, the organ uncut; forces are
  /// kept (released if a cut is taken back: their nodes were the cut model's). The way on after
  /// the simulation became unstable (LoopSnapshot::stats.unstable): the loop stops stepping then,
  /// and its reaction is zero, so that a haptic device feels nothing wild.
  void reset() { loop_.reset(); }

  /// Copies the latest snapshot into `out` if it is newer than out.generation.
  /// @return true if `out` was updated
  bool latest(LoopSnapshot& out) const;

  /// The reaction force after the last step (cheap: no positions are copied).
  interact::ReactionSample latest_reaction() const { return loop_.latest_reaction(id_); }

  /// Runs `steps` steps on the calling thread (the loop must not be running): for tests and
  /// fixed-step tools that want the same physics without a thread.
  void run_steps(int64_t steps) { loop_.run_steps(steps); }

 private:
  WorldLoop loop_;
  BodyId id_;
  const bool real_time_;
  mutable std::mutex mutex_;  // guards world_: the world's snapshot latest() translates
  mutable WorldSnapshot world_;
};

}  // namespace lamina::world
