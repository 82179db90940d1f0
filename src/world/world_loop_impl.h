#pragma once
// The world loop's state (private to module world): the world, the callers' commands guarded by
// `mutex`, the stepping thread's own state, and the published snapshot guarded by
// `snapshot_mutex`. world_loop.cpp and world_loop_publish.cpp share it.
#include <condition_variable>
#include <future>
#include <mutex>
#include <optional>
#include <utility>
#include <vector>

#include "lamina/core/clock.h"
#include "lamina/core/lock_waits.h"
#include "lamina/interact/haptic_proxy.h"
#include "lamina/world/cut_body.h"
#include "lamina/world/cut_history.h"
#include "lamina/world/world_loop.h"

namespace lamina::world {

struct WorldLoop::Impl {
  Impl(World w, WorldLoopOptions o) : world(std::move(w)), options(std::move(o)) {}

  World world;
  WorldLoopOptions options;

  // Commands from the callers, guarded by mutex.
  mutable std::mutex mutex;
  std::condition_variable wake;
  bool stop_requested = false, paused = false, reset_requested = false, clear_all_forces = false;
  struct NewForces {
    int32_t slot;
    uint32_t topology;  // the one they were checked against: older when taken, they are dropped
    std::vector<interact::LiveForce> forces;
  };
  std::vector<NewForces> new_forces;
  struct Stroke {
    std::vector<Eigen::Vector3d> path;
    Eigen::Vector3d direction;
    double depth_mm, reach_mm;
    bool cuts_tissue = false;  // cut(): the bodies' tetrahedra too, not only the ties
  };
  std::vector<Stroke> strokes;
  double rate_hz = 1000.0;
  std::optional<interact::ToolTip> new_tip;
  std::optional<interact::Jaws> new_close;                // where the caller closed the jaws
  std::optional<std::optional<interact::Jaws>> new_jaws;  // their latest place, or open
  bool jaws_closed = false;   // as the caller last set them (set_grasper's own bookkeeping)
  bool close_failed = false;  // the stepping thread could not close them: the next jaws close
  // The live bodies, their topology generations and skins' sizes: what a caller's handle and
  // nodes are checked against, on the caller's thread.
  struct Handle {
    BodyId id;
    uint32_t topology = 0;
    int32_t skin_nodes = 0;
    int32_t rings_locality = 0;  // what its routing's locality may reach
  };
  std::vector<Handle> handles;
  const Handle& handle_of(BodyId id) const;  // under mutex; throws for a stale one
  struct NewParams {
    int32_t slot;
    sim::Material material;
    sim::SolverOptions solver;
    interact::RoutingOptions routing;
    bool worlds_dt = false;  // Dt::kTheWorlds: solver.dt_s replaced by the world's when taken
  };
  std::vector<NewParams> new_params;  // the newest per body
  int new_undos = 0;

  // The stepping thread's.
  double stepping_rate_hz = 1000.0;
  struct Live {  // a body's live forces (routed into its tools' live_routes)
    std::vector<interact::LiveForce> forces;
  };
  std::vector<Live> live;  // per body slot
  // The hands (world_loop_hands.cpp): the tool tip with a haptic proxy per body slot (its load
  // on the body is the body's tools' `tip`), and the grasper: where it closes (not yet done),
  // where it is, and the body whose tools' `hand` holds what it holds.
  interact::ToolTip tip;
  std::vector<interact::HapticProxy> tip_proxies;  // per body slot
  std::optional<interact::Jaws> close_at, jaws;
  int32_t grasp_slot = -1;
  std::vector<Eigen::Vector3d> body_reaction_mn;  // per body slot: its push on the hands
  std::vector<int32_t> tip_contact;               // per body slot: the tip's contact node, or -1
  std::vector<uint8_t> warned_inside;             // per body slot: the device-inside warning logged
  // Per body slot: counts the changes of its material, solver or dt (a cut prepared before one
  // sets the body's parameters of now on the cut simulation).
  std::vector<uint64_t> parameters;
  Eigen::Vector3d hands_reaction_mn() const;  // the sum: the snapshot's, the device's
  WorldStepStats stats;
  interact::RateWindow window;
  double late_us = 0.0;
  bool stepping_paused = false;  // paused as last taken under mutex
  int32_t strokes_divided = 0;
  std::vector<Stroke> tissue_cuts;  // taken from `strokes`, cut outside the lock
  // A cut being made on another thread while the world steps on (world_loop_cuts.cpp): each
  // body the blade divides, prepared from copies of it (interact::prepare_cut), then taken in
  // between two steps (world::take_cut). One at a time; the next stroke waits for it.
  struct CutJob {
    Stroke stroke;
    uint64_t resets = 0;  // the loop's resets when it began: a reset since drops it
    double began_s = 0.0;
    int64_t steps = 0;  // the world's when it began
    struct OnBody {
      BodyId id;
      uint32_t topology = 0;    // the body's when it began: a change since drops its part
      uint64_t parameters = 0;  // the body's parameters' count when it began
      interact::PreparedCut cut;
    };
    std::vector<OnBody> bodies{};  // those it divides
    std::string skipped{};         // "NAME: why" of those it could not cut
  };
  std::future<CutJob> cut_job;
  uint64_t resets = 0;
  int stepping_threads = 0;   // the stepping thread's own, set back once the job is taken
  bool threaded = false;      // stepping on the loop's thread (not run_steps())
  double cut_begin_ms = 0.0;  // the stepping thread's time copying the bodies for the job
  double last_cut_made_ms = 0.0;
  int64_t last_cut_steps_meanwhile = 0;
  // The cuts since the last reset (cut_history.h): an undo takes the newest back, a reset all.
  CutHistory history;
  int undos = 0;  // taken from new_undos, done when no cut is being made
  int32_t cuts = 0;
  int64_t tets_cut = 0;
  double last_cut_ms = 0.0;
  double longest_cut_ms = 0.0;  // since the loop was made (a reset keeps it)
  std::string cut_message;
  std::vector<std::pair<std::string, model::CutReport>> last_cut;  // the snapshot's
  uint64_t cut_events = 0;
  sim::Instability unstable = sim::Instability::kNone;
  std::string unstable_body;
  double last_publish_s = -1.0;
  LockWaits lock_waits;

  // The published snapshot; the hands' reaction, every step.
  mutable std::mutex snapshot_mutex;
  WorldSnapshot published;
  mutable std::mutex reaction_mutex;
  interact::ReactionSample reaction;
  std::vector<Eigen::Vector3d> tools_reaction;  // per body slot: BodyView::reaction_mn

  bool halted() const { return unstable != sim::Instability::kNone; }
  void follow_the_clock();  // every body's dt = 1 / rate in real time
  void apply_pending();     // under mutex
  void route_forces(int32_t slot);
  // The stepping thread's, outside mutex (world_loop_cuts.cpp): a cut job taken in when done,
  // the next stroke's begun; without the loop's thread, each is waited for.
  void apply_cuts();
  void begin_cut(Stroke stroke);
  void take_cut(bool wait);
  void apply_undos();
  void apply_parameters();  // under mutex: new_params
  // Under mutex: a body renumbered, by a cut (`origin`: its live forces carried to their nodes'
  // first copies) or put back (none: they are released).
  void topology_changed(int32_t slot, const std::vector<int32_t>* origin = nullptr);
  // The hands (world_loop_hands.cpp).
  void take_hands();              // under mutex: the tip and jaws the callers set
  void move_hands();              // before each step: the tip's loads, the jaws
  void open_grasper();            // the held body let go
  void forget_tip(int32_t slot);  // a body renumbered: the tip's load and proxy on it start over
  const interact::Grasp* held() const;  // what the grasper holds, or null when open
  void one_step();
  void publish(bool force);  // world_loop_publish.cpp
};

}  // namespace lamina::world
