#pragma once
/// \file
/// A simulation running in its own thread at a fixed rate (1 kHz by default, a haptic device's
/// rate), decoupled from whoever draws it. The caller sets forces and parameters at any time;
/// they take effect between two steps. The loop publishes a snapshot of the state (positions,
/// step statistics, achieved rate, jitter, the tissue's reaction force) that the caller copies
/// when it wants to draw: double-buffered, so neither side waits for the other.
///
/// Only the loop's thread touches the Simulation while it runs; every public member function is
/// safe to call from any one other thread.

#include <Eigen/Core>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "lamina/core/lock_waits.h"
#include "lamina/interact/grasp.h"
#include "lamina/interact/haptic_proxy.h"
#include "lamina/interact/prepared_cut.h"
#include "lamina/interact/rate_window.h"
#include "lamina/interact/reaction_sample.h"
#include "lamina/interact/tools.h"
#include "lamina/model/cut_tetrahedra.h"
#include "lamina/sim/simulation.h"

namespace lamina::interact {

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
  RoutingOptions routing;
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
  /// The longest the stepping thread spent on a cut between two steps, us: beginning it on
  /// another thread, or taking it in once made (RealtimeLoop::cut()); the cut itself, tens to
  /// hundreds of milliseconds, is made while the loop steps on.
  double longest_cut_pause_us = 0.0;
  /// The model x is of: the one the loop was made with until a cut (RealtimeLoop::cut()) made
  /// another; model_version counts the changes of model (each cut that divided tetrahedra, each
  /// undo: 0, the loop's own).
  std::shared_ptr<const Model> model;
  uint64_t model_version = 0;
  /// The cuts in force: how many divided tetrahedra (less those undone), the last one's report
  /// (its pieces, the structures it crossed, where they are then; empty after an undo), and a
  /// cut or undo refused on the stepping thread (empty if none; a bad path is refused by cut()
  /// itself). `undoable`: how many of the last cuts undo_cut() can take back.
  int64_t cuts = 0;
  int32_t undoable = 0;
  model::CutReport last_cut;
  std::string cut_error;
};

class RealtimeLoop {
 public:
  /// Takes over `sim` (its model must outlive the loop). Does not start stepping.
  RealtimeLoop(sim::Simulation sim, const RoutingOptions& routing, const LoopOptions& options = {});
  ~RealtimeLoop();  ///< stops the thread
  RealtimeLoop(const RealtimeLoop&) = delete;
  RealtimeLoop& operator=(const RealtimeLoop&) = delete;

  void start();  ///< starts the thread (no-op if running)
  void stop();   ///< stops and joins the thread (no-op if stopped)
  bool running() const { return thread_.joinable(); }

  /// Replaces every user force (an empty list releases them all: the organ returns to rest).
  void set_forces(std::vector<LiveForce> forces);
  void set_tool_tip(const ToolTip& tip);
  /// The grasper: jaws given and open, they close on the skin under them (its free nodes within
  /// jaws.radius_mm, at that position, on the shape of the next step) and hold it; given and
  /// closed, they move there with what they hold (moves made before the loop's next step still
  /// close at the first position); nullopt opens them. The tissue's pull on the held nodes joins
  /// the reaction. Throws lamina::Error (kInvalidInput), nothing changing, for a radius or position
  /// that is not a finite positive number, or when closing with no skin node within the radius
  /// in the latest snapshot ("nothing under the jaws").
  void set_grasper(const std::optional<Jaws>& jaws);
  /// New parameters, checked now (throws lamina::Error kInvalidInput, nothing changes), applied
  /// before the next step.
  void set_parameters(const sim::Material& material, const sim::SolverOptions& solver,
                      const RoutingOptions& routing);
  /// New rate (0 = as fast as possible). In real time the step becomes 1 / rate_hz.
  void set_rate(double rate_hz);
  void set_paused(bool paused);
  /// Cuts the organ at once with a scalpel drawn on its current shape (interact::cut_now():
  /// the blade's upper end along `path`, reaching depth_mm along `direction`), between two
  /// steps; the live forces, the grasper's hold and the tip carry over to the cut model, whose
  /// nodes are numbered anew (LoopSnapshot::model, model_version: a caller that names nodes
  /// takes them from the new model). Throws lamina::Error (kInvalidInput), nothing queued, for
  /// a bad path, depth or direction (scalpel_problem()).
  void cut(std::vector<Eigen::Vector3d> path, const Eigen::Vector3d& direction, double depth_mm);
  /// Takes the last cut back, between two steps: the model, the organ's shape and motion, the
  /// live forces, the grasper's hold and the tip as they were just before it (the clock runs
  /// on). The last kUndoDepth cuts can be undone, one call each; with none, the snapshot's
  /// cut_error says so and nothing changes.
  void undo_cut();
  static constexpr int kUndoDepth = 8;
  /// Puts every node back at rest with zero velocity and time 0; forces are kept. The way on
  /// after the simulation became unstable (LoopSnapshot::stats.unstable): the loop stops
  /// stepping then, and its reaction is zero, so that a haptic device feels nothing wild.
  void reset();

  /// Copies the latest snapshot into `out` if it is newer than out.generation.
  /// @return true if `out` was updated
  bool latest(LoopSnapshot& out) const;

  /// The reaction force after the last step (cheap: no positions are copied).
  ReactionSample latest_reaction() const;

  /// Runs `steps` steps on the calling thread (the loop must not be running): for tests and
  /// fixed-step tools that want the same physics without a thread.
  void run_steps(int64_t steps);

  /// The model the loop was made with, or the last cut's (only while the loop is stopped, or
  /// from the stepping thread: a running loop's cut replaces it; LoopSnapshot::model otherwise).
  const Model& model() const { return sim_.model(); }

 private:
  void thread_main();
  // Unstable (sim::Instability): the loop stops stepping, and its reaction is zero, until reset().
  bool halted() const { return last_stats_.unstable != sim::Instability::kNone; }
  void apply_pending();      // under mutex_
  void apply_cut();          // a cut taken by apply_pending: begun on another thread, or taken in
  void take_cut(bool wait);  // the cut made on the other thread, once done (or waited for)
  void apply_undo();         // an undo taken by apply_pending
  void route_forces();
  void move_grasper();
  void one_step();
  void publish(bool force);
  void follow_the_clock(double rate_hz);  // dt = 1 / rate in real time
  // Locks `lock` for the stepping thread, counting the wait when a caller holds it.
  void acquire(std::unique_lock<std::mutex>& lock);

  sim::Simulation sim_;
  // Everything that names the organ's nodes besides the simulation: the live forces' routes,
  // the tip's load, the grasper's hold, the loads and the nodes kept movable; the routing. One
  // driver, stepped by apply_tools() and carried through a cut by carry_tools(), as a world's
  // body's tools are.
  ToolDriver tools_;
  LoopOptions options_;
  // The model's rings' locality, for the callers' checks (sim_ is the stepping thread's: a cut
  // replaces it; a cut model's rings have the same locality).
  const int32_t rings_locality_;

  // Commands from the caller, guarded by mutex_.
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_requested_ = false, paused_ = false, reset_requested_ = false;
  std::optional<std::vector<LiveForce>> new_forces_;
  std::optional<ToolTip> new_tip_;
  std::optional<std::optional<Jaws>> new_jaws_;
  std::optional<Jaws> new_close_;  // where the jaws were when the caller closed them
  bool jaws_closed_ = false;       // as the caller last set them (set_grasper's own bookkeeping)
  struct Params {
    sim::Material material;
    sim::SolverOptions solver;
    RoutingOptions routing;
  };
  std::optional<Params> new_params_;
  struct CutRequest {
    std::vector<Eigen::Vector3d> path;
    Eigen::Vector3d direction;
    double depth_mm;
  };
  std::optional<CutRequest> new_cut_;
  int new_undos_ = 0;
  double rate_hz_ = 1000.0;

  // Owned by the stepping thread.
  // The rate it steps at: rate_hz_ as last taken under mutex_ (apply_pending); the real-time
  // check once read rate_hz_ itself, unlocked (found by TSan in CI's run).
  double stepping_rate_hz_ = 1000.0;
  std::vector<LiveForce> forces_;
  std::optional<CutRequest> cut_;  // taken from new_cut_, made outside the lock
  int undos_ = 0;                  // taken from new_undos_
  // What each of the last cuts changed, to take it back: everything that names the nodes.
  struct BeforeCut {
    std::shared_ptr<const Model> model;
    sim::Simulation sim;
    std::vector<LiveForce> forces;
    ToolDriver tools;
    uint64_t params_version = 0;  // params_version_ when the cut was taken in
  };
  std::vector<BeforeCut> undo_;  // the oldest first, at most kUndoDepth
  // A cut being made on another thread while the loop steps on (the model divided and a
  // simulation of it made and prepared: the slow part); take_cut() puts the state of the moment
  // into it between two steps.
  struct CutJob {
    std::shared_ptr<const Model> own;        // a copy of the caller's model, the first time
    std::optional<sim::Simulation> own_sim;  // a simulation of it (what an undo goes back to)
    PreparedCut cut;                         // the cut model and its simulation (prepared_cut.h)
    std::string error;
  };
  std::future<CutJob> cut_job_;
  uint64_t params_version_ = 0;      // each change of material, options or dt
  uint64_t cut_params_version_ = 0;  // params_version_ when the cut job began
  int stepping_threads_ = 0;         // the stepping thread's own, set back after a cut job
  double longest_cut_pause_us_ = 0.0;
  std::shared_ptr<const Model> model_;  // the model sim_ runs on (not owned until a cut)
  uint64_t model_version_ = 0;
  int64_t cuts_ = 0;
  model::CutReport last_cut_;
  std::string cut_error_;
  ToolTip tip_;
  int32_t tip_contact_ = -1;
  HapticProxy proxy_;             // the tip's god-object and the force on the device
  std::optional<Jaws> jaws_;      // the grasper, when closed: where the caller last put it
  std::optional<Jaws> close_at_;  // where they close (the caller's first position), not yet done
  bool warned_inside_ = false;    // the device-inside-the-organ warning was logged for this entry
  double last_publish_s_ = -1.0;
  sim::StepStats last_stats_;
  RateWindow window_;     // the last second's rate, step time, jitter and real-time factor
  double late_us_ = 0.0;  // how late the current step started, us
  LockWaits lock_waits_;

  // The last step's reaction, guarded by reaction_mutex_ (a lock per step, held for a copy of
  // five numbers: the snapshot's lock is held while positions are copied).
  mutable std::mutex reaction_mutex_;
  ReactionSample reaction_;

  // The published snapshot, guarded by snapshot_mutex_.
  mutable std::mutex snapshot_mutex_;
  LoopSnapshot published_;

  std::thread thread_;
};

}  // namespace lamina::interact
