#pragma once
/// \file
/// `lamina view`'s session on the viewer engine (render/viewer.h): it owns the simulation (an
/// world::OrganLoop in its own thread), turns the engine's input into the reference paper's
/// drag (force = gain x drag, Shift pins it), tool tips and camera moves, replays scripted input,
/// builds the panels, rebuilds the model in the background, and writes the report, the
/// screenshots and the deformed skin. It uses the engine's API only, so it runs the same on a
/// window, on EGL and on the mock backend (tests).
///
///     ViewSession session(options, std::move(model));     // reads the script
///     render::init({.width = 1400, .height = 900,
///                   .platform_mouse = !session.script_drives_mouse()});
///     session.run();                          // start(), frame() until closed, finish()
///     render::shutdown();
///
/// Mouse: left-drag on the organ pushes or pulls it with a force proportional to the drag; hold
/// Shift when releasing to pin the force, so several act at once; release without Shift and the
/// organ returns to rest. Left-drag elsewhere orbits, right- or middle-drag pans, the wheel
/// zooms. In tool-tip mode a sphere follows the mouse while the left button is held and the wheel
/// pushes it in or pulls it out. Keys: R reset, Space pause, C release pinned forces, T toggle
/// tool-tip mode, S screenshot (docs/viewer.md).

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "lamina/core/progress.h"
#include "lamina/interact/tools.h"
#include "lamina/model/model.h"
#include "lamina/model/surface_support.h"
#include "lamina/sim/simulation.h"
#include "lamina/world/organ_loop.h"

namespace lamina::cli {

/// A model to view, with what the viewer cannot guess.
struct ViewModel {
  Model model;
  std::vector<int32_t> fixed;     ///< nodes held at rest (the boundary)
  model::SurfaceSupport support;  ///< nodes held elastically (the body around the organ)
  /// The material as resolved for this model (a rebuilt model's damping follows its own slowest
  /// vibration); unset: the session keeps the one it has.
  std::optional<sim::Material> material;
  std::string source;  ///< shown in the title bar and panels
  /// Forces acting from the start (pinned), e.g. a scene's tools: skin node and force in mN.
  std::vector<std::pair<int32_t, Eigen::Vector3d>> pinned;
  /// A scene's grasper (its first): its jaws close at its point when the session starts, follow
  /// its pull over pull_s of simulated time and then hold, as a Shift-held grasp (C opens them,
  /// R closes them again at the start, a new grasp replaces them). Its point is resolved.
  std::optional<interact::Tool> grasper;
  int32_t watched_node = -1;  ///< node whose displacement is plotted at first; -1 = first pinned
};

/// Rebuilds the model with other layer counts or resolution (from the Model panel or a script).
/// Runs on a worker thread; reports progress through `progress`.
using RebuildFn =
    std::function<ViewModel(int32_t layers, int32_t skin_vertices, const ProgressFn& progress)>;

struct ViewOptions {
  double rate_hz = 1000.0;  ///< simulation steps per wall second; 0 = as fast as possible
  /// Start at rate_hz and step at the highest rate the machine keeps (interact::next_rate(),
  /// checked each second; said on screen and in the log); the Model panel's rate ends it.
  bool auto_rate = false;
  /// Drag force per mm of drag. Lower than the scene files' 0.05: a mouse drags 100 mm easily,
  /// and 1 N already dents the paper's K = 3 N/m model by about 20 mm.
  double gain_n_per_mm = 0.01;
  sim::Material material;  ///< start values of the panels
  sim::SolverOptions solver;
  interact::RoutingOptions routing;
  RebuildFn rebuild;  ///< empty: the Model panel cannot rebuild
  /// Scripted input (docs/viewer.md): a JSON file of timed mouse, key and screenshot events,
  /// injected into the engine like the window's own events. For tests, demos and recordings.
  std::string script;
  /// Where to write a JSON report when the session finishes (frames, steps, achieved rate,
  /// largest displacement...); empty = none.
  std::string report;
};

/// Reads and checks a scripted-input file without opening anything.
/// \note Throws lamina::Error (kInvalidInput) "PATH: events[i].key: problem".
void check_view_script(const std::string& path);

class ViewSession {
 public:
  /// The name the model is registered under in the engine.
  static constexpr const char* kModelName = "organ";

  /// Reads the script, if any; touches neither the engine nor any thread.
  /// \note Throws lamina::Error (kInvalidInput) for a malformed script.
  ViewSession(ViewOptions options, ViewModel model);
  ~ViewSession();  ///< stops the simulation and waits for a rebuild in progress
  ViewSession(const ViewSession&) = delete;
  ViewSession& operator=(const ViewSession&) = delete;

  /// Whether the session's script moves the mouse (then the window's own mouse should be
  /// ignored: render::ViewerOptions::platform_mouse = false).
  bool script_drives_mouse() const;

  /// Registers the model with the engine (render::init() must have been called), starts the
  /// simulation and the script's clock, and installs the session's per-frame callback.
  void start();
  /// The script's events due by now, then one engine frame.
  /// @return false once the window was closed or the script quit
  bool frame();
  /// Stops the simulation, writes the report (if asked) and says on stderr if the simulation
  /// fell behind real time. Removes the engine callback.
  void finish();
  /// start(), frame() at up to 60 frames a second (down to 15 while the simulation cannot keep
  /// up), finish(). @return 0
  int run();

  /// The report's content as of now (docs/viewer.md lists its keys).
  nlohmann::json report() const;
  /// The simulation's latest state as the last frame saw it.
  const world::LoopSnapshot& snapshot() const;
  /// The current model (replaced by a rebuild).
  const Model& model() const;
  /// What the last left-button press did and why: "drag node N", or why it did not drag
  /// ("a panel has the mouse", "missed the organ: orbit", ...). Also logged at debug level.
  const std::string& last_press() const;

  struct State;  ///< defined in view_session_state.h (the session's files share it)

 private:
  std::unique_ptr<State> state_;
};

}  // namespace lamina::cli
