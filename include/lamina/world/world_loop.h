#pragma once
/// \file
/// A world stepping in its own thread at the wall clock's pace (world::step, one step every
/// 1 / rate seconds), decoupled from whoever draws it: the viewer runs a world scene with it
/// (docs/world.md, "The world in real time"), and one organ is a world of one body
/// (world::OrganLoop, organ_loop.h). Callers push and pull bodies with live forces, sweep a blade
/// through the attachments, pause, reset and change the rate at any time; the commands take effect
/// between two steps. The loop publishes a snapshot (every body's positions, model and topology
/// generation, the ties, the stages' times, the achieved rate) that a caller copies when it
/// draws: neither side waits for the other.
///
/// Only the loop's thread touches the World while it runs; every public member function is safe
/// to call from any one other thread. A command naming a body by a stale handle, or by nodes of
/// an older topology generation of it, is refused (lamina::Error kInvalidInput), not applied to
/// whatever holds that slot or those numbers now.
///
///     world::WorldLoop loop(std::move(ready->world), {.dissections = scene.dissections});
///     loop.start();
///     world::WorldSnapshot snap;
///     while (drawing) { if (loop.latest(snap)) draw(snap); }

#include <Eigen/Core>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "lamina/interact/grasp.h"
#include "lamina/interact/rate_window.h"
#include "lamina/interact/reaction_sample.h"
#include "lamina/interact/tools.h"
#include "lamina/model/cut_tetrahedra.h"
#include "lamina/world/cut_history.h"
#include "lamina/world/dissection.h"
#include "lamina/world/world.h"

namespace lamina::world {

struct WorldLoopOptions {
  /// Steps per wall-clock second; 0 = as fast as possible, at the bodies' own dt.
  double rate_hz = 1000.0;
  /// Real time: every body's step becomes 1 / rate_hz, so that the simulated clock follows the
  /// wall clock; when the machine cannot keep up the snapshot says so (rate.keeping_up), dt is
  /// never stretched to hide it. false: the bodies' dt whatever the rate.
  bool real_time = true;
  /// Threads each step may use; 0 = OpenMP's default (a viewer drawing on the same cores sets 1,
  /// as it does for one organ).
  int threads = 0;
  /// Minimum wall time between two published snapshots, s.
  double publish_interval_s = 1.0 / 240.0;
  /// A scene's blades, on the world's clock (a reset plays them again from the start).
  std::vector<Dissection> dissections;
  /// cut() divides the bodies on another thread while the world steps on, and takes the cut
  /// in between two steps (as the one-organ loop does: LoopOptions::background_cuts); false,
  /// or run_steps(), makes it between two steps on the stepping thread, which waits for it
  /// (65 ms at paper size).
  bool background_cuts = true;
};

/// One body as the loop last published it.
struct BodyView {
  BodyId id;
  std::string name;
  std::shared_ptr<const Model> model;
  uint32_t topology = 0;  ///< the body's topology generation: node numbers are of this one
  Eigen::MatrixX3d x;     ///< #nodes by 3, mm
  BodyStepStats stats;    ///< its part of the last step
  /// The skin nodes the live forces are on, in the order they were set (a cut carries them)
  std::vector<int32_t> force_nodes;
  std::vector<int32_t> grasped_nodes;  ///< what the grasper holds of it (empty: none)
  /// Its tissue's push on the hands (the tool tip's device and the grasper), mN.
  Eigen::Vector3d hands_reaction_mn = Eigen::Vector3d::Zero();
  /// Its tissue's push on every live tool on it after the last step, mN: the live forces', the
  /// tip's device force and the grasper's pull (interact::live_reaction; zero once unstable).
  /// What the one-organ loop renders (LoopSnapshot::reaction_mn).
  Eigen::Vector3d reaction_mn = Eigen::Vector3d::Zero();
  /// Where the live forces' routes touch it (each route's contact node), then the tool tip's
  /// contact node while it touches it.
  std::vector<int32_t> contact_nodes;
  bool tip_touching = false;
  /// Per node, 1 = held where it is (fixed, or held by a grasp): jaws close on the others only.
  std::vector<uint8_t> fixed;
  int64_t recoveries = 0;  ///< steps redone after leaving bounds (sim::Simulation::recoveries)
  bool multigrid = false;  ///< its implicit solve preconditioned by multigrid (else Jacobi)
  /// Its parameters as they step now (set_parameters(); dt is the world's).
  sim::Material material;
  sim::SolverOptions solver;
  interact::RoutingOptions routing;
};

/// An active tie as drawn: its node and its point on the other skin, and its pull.
struct TieLine {
  Eigen::Vector3d from = Eigen::Vector3d::Zero(), to = Eigen::Vector3d::Zero();
  double pull_mn = 0.0;
};

/// What the loop last published. Everything is a copy: valid as long as the caller keeps it.
struct WorldSnapshot {
  std::vector<BodyView> bodies;  ///< the live bodies, in slot order
  std::vector<TieLine> ties;     ///< active ties
  TieCount tie_count;
  WorldProfile profile;  ///< the last step's stages, us
  double step_us = 0.0;  ///< the last step's
  double time_s = 0.0;   ///< simulated
  int64_t steps = 0;
  double dt_s = 0.0;
  uint64_t generation = 0;    ///< increases with each publication
  interact::RateWindow rate;  ///< the last whole second: achieved rate, real-time factor...
  bool paused = false;
  /// Every body at rest and no tie torn in the last step.
  bool converged = false;
  /// Set when a body became unstable: the loop stops stepping until reset().
  sim::Instability unstable = sim::Instability::kNone;
  std::string unstable_body;
  int32_t ties_divided_by_strokes = 0;  ///< by dissect() and cut() since the last reset
  /// Cuts through the bodies' tissue since the last reset (cut(): one per body divided), the
  /// tetrahedra they divided; the last one's time on the stepping thread, ms (copying the bodies
  /// for it and taking it in between two steps; with background_cuts off, making it too), from
  /// the stroke taken to the cut taken in, ms, and the world's steps in between.
  int32_t cuts = 0;
  int64_t tets_cut = 0;
  double last_cut_ms = 0.0;
  double last_cut_made_ms = 0.0;
  int64_t last_cut_steps_meanwhile = 0;
  /// The longest of the cuts' times on the stepping thread (last_cut_ms) since the loop was made.
  double longest_cut_ms = 0.0;
  /// Why the last cut() divided no tissue, or an undo_cut() with no cut to take back; or empty.
  std::string cut_message;
  /// What the last stroke that cut tissue did to each body it divided, by name (what it divided,
  /// the pieces, the structures crossed: the world's LaminaCut; empty after an undo), and a count
  /// that moves on with each such stroke, each undo and each reset (news since a caller last
  /// looked).
  std::vector<std::pair<std::string, model::CutReport>> last_cut;
  uint64_t cut_events = 0;
  /// How many of the last cuts undo_cut() can take back.
  int32_t undoable = 0;
  /// The hands (set_tool_tip(), set_grasper()): the tissue's push back on them, mN (the tip's
  /// haptic proxies' forces and the grasper's pull: what a haptic device or a controller's
  /// vibration renders), whether the tip touches a body, and what the grasper holds: the body
  /// (empty when open) and how many of its skin nodes.
  Eigen::Vector3d hands_reaction_mn = Eigen::Vector3d::Zero();
  bool tip_touching = false;
  std::string grasped_body;
  int32_t grasped_nodes = 0;
  /// How many times the stepping thread found a lock held by a caller, and its longest wait, us.
  int64_t lock_waits = 0;
  double longest_lock_wait_us = 0.0;
};

/// Where a caller's live forces on a body are after its topology moved on (from the snapshot it
/// set them on to `now`): a cut carries them to their nodes' first copies, an undo back to the
/// nodes the copies came from (now.force_nodes, in the order they were set); a reset releases
/// them.
/// @return per force of `sent`, its node in now's numbering; nullopt if they were released
std::optional<std::vector<int32_t>> carried_force_nodes(
    const BodyView& now, const std::vector<interact::LiveForce>& sent);

class WorldLoop {
 public:
  /// Takes over `world` (every body stepping at the same dt, as create_body() requires). Does not
  /// start stepping.
  /// \note Throws lamina::Error (kInvalidInput) for a world with no body or options out of range.
  explicit WorldLoop(World world, WorldLoopOptions options = {});
  ~WorldLoop();  ///< stops the thread
  WorldLoop(const WorldLoop&) = delete;
  WorldLoop& operator=(const WorldLoop&) = delete;

  void start();  ///< starts the thread (no-op if running)
  void stop();   ///< stops and joins the thread (no-op if stopped)
  bool running() const { return thread_.joinable(); }

  /// Replaces the live forces on `body` (an empty list releases them): each on a skin node of
  /// the body's topology generation `topology`, routed on the shape of the moment as the
  /// one-organ loop routes them. The other bodies' forces are kept.
  /// \note Throws lamina::Error (kInvalidInput), nothing changing, for a stale handle, an older
  ///   topology generation, a node that is not on the body's skin or a force that is not finite.
  void set_forces(BodyId body, uint32_t topology, std::vector<interact::LiveForce> forces);
  /// Releases every body's live forces.
  void clear_forces();
  /// Sweeps a blade through the world at once, between two steps (dissect_along()): the upper
  /// end along `path`, the lower end depth_mm along `direction`, dividing the ties within
  /// reach_mm of it.
  /// \note Throws lamina::Error (kInvalidInput), nothing queued, for a blade a scalpel could not
  ///   be (model::blade_problem: fewer than two finite points, a path of no length, a depth that
  ///   is not positive, a direction that is not finite and non-zero or runs along the path) or a
  ///   reach that is not a positive number.
  void dissect(std::vector<Eigen::Vector3d> path, const Eigen::Vector3d& direction, double depth_mm,
               double reach_mm = 1.5);
  /// Cuts every body the blade passes through (cut_body(): the blade's upper end along `path`,
  /// reaching depth_mm along `direction`, drawn on the bodies as they are when the loop takes
  /// the stroke; made on another thread while the world steps on and taken in between two
  /// steps: WorldLoopOptions::background_cuts), and divides the ties within reach_mm of it as
  /// dissect() does. Strokes are cut one after another; a reset drops a cut being made. A body cut
  /// moves to a new topology generation: its live forces go on, carried to their nodes' first
  /// copies (each copy taking its share of the load, as the one-organ loop carries them; the
  /// snapshot's force_nodes give their new nodes, carried_force_nodes() a caller's); a caller
  /// sets them again on the new generation's nodes. reset() puts the uncut bodies back.
  /// \note Throws lamina::Error (kInvalidInput), nothing queued, for a blade as dissect() does.
  void cut(std::vector<Eigen::Vector3d> path, const Eigen::Vector3d& direction, double depth_mm,
           double reach_mm = 1.5);
  /// Takes the last cut() back, between two steps: every body it divided as it was just before
  /// it (its model, shape and motion, the ties then), the clock running on and the parameters
  /// set since kept. Each such body moves to a new topology generation (its live forces carried
  /// back to the nodes their copies came from, the grasper opened if it held it). The last
  /// kUndoDepth cuts can be undone, one call each; a cut being made is waited for first; with none,
  /// the snapshot's cut_message says so.
  void undo_cut();
  static constexpr int kUndoDepth = static_cast<int>(CutHistory::kDepth);
  /// Whose dt set_parameters() takes: the caller's solver.dt_s, or the world's as it is when
  /// the parameters are taken (solver.dt_s not looked at: a panel that changed a stiffness, not
  /// dt, whose snapshot may predate a new rate or the clock's own change).
  enum class Dt { kGiven, kTheWorlds };
  /// New parameters for `body`, checked now and taken between two steps: its material
  /// (sim::set_parameters: new E or nu identify its springs again), its solver and the routing
  /// of its live forces. Every body steps at the world's dt (1 / rate in real time: change the
  /// rate instead): with Dt::kGiven, a new dt is every body's without real time, and in real time
  /// solver.dt_s must be the latest snapshot's dt_s.
  /// \note Throws lamina::Error (kInvalidInput), nothing changing, for a stale handle, parameters
  ///   sim::check_parameters() or interact::check_routing() refuses, or another dt in real time.
  void set_parameters(BodyId body, const sim::Material& material, const sim::SolverOptions& solver,
                      const interact::RoutingOptions& routing, Dt dt = Dt::kGiven);
  /// The tool tip (a haptic device's or a headset controller's sphere; `tip.active` false lifts
  /// it): every step it pushes each body it touches through that body's own haptic proxy and
  /// coupling (interact::load_of_tip, as the one-organ loop's tip), the force on it the sum.
  /// \note Throws lamina::Error (kInvalidInput), nothing changing, for a tip
  ///   interact::tip_problem() refuses.
  void set_tool_tip(const interact::ToolTip& tip);
  /// The grasper: jaws given while it is open close on the body whose skin is nearest their
  /// centre (every free skin node of it within jaws.radius_mm held, interact::close_jaws), on
  /// the next step's shape; given again while closed they move what they hold; nullopt opens
  /// them. A cut of the held body carries the hold to the copies; an undo of that cut, or a
  /// reset, opens them.
  /// \note Throws lamina::Error (kInvalidInput), nothing changing, for jaws that are not finite
  ///   or a radius that is not positive, and, when closing, for no body's skin under the jaws
  ///   (on the latest snapshot).
  void set_grasper(const std::optional<interact::Jaws>& jaws);
  /// New rate (0 = as fast as possible). In real time every body's step becomes 1 / rate_hz.
  void set_rate(double rate_hz);
  void set_paused(bool paused);
  /// Every body back at rest, every tie in place and the clock at 0 (the scene's tools and
  /// blades play again); a body cut since is put back uncut (its topology generation moves on
  /// and its live forces are released); the other live forces are kept. The way on after an
  /// instability.
  void reset();

  /// Copies the latest snapshot into `out` if it is newer than out.generation.
  /// @return true if `out` was updated
  bool latest(WorldSnapshot& out) const;

  /// Runs `steps` steps on the calling thread (the loop must not be running): the same physics
  /// without a thread, for tests and fixed-step tools.
  void run_steps(int64_t steps);

  /// The hands' reaction after the last step (the snapshot's hands_reaction_mn): every step, where
  /// snapshots come at most every publish_interval_s, and cheap (no positions are copied): what a
  /// 1 kHz haptic loop reads.
  interact::ReactionSample latest_reaction() const;
  /// `body`'s tissue's push on every live tool on it after the last step, every step
  /// (BodyView::reaction_mn); zero for a stale handle.
  interact::ReactionSample latest_reaction(BodyId body) const;

  /// The live bodies' handles and their topology generations as of the latest snapshot.
  std::vector<std::pair<BodyId, uint32_t>> bodies() const;

 private:
  struct Impl;  // world_loop.cpp: the world, the commands and the stepping thread's state
  void thread_main();
  std::unique_ptr<Impl> impl_;
  std::thread thread_;
};

}  // namespace lamina::world
