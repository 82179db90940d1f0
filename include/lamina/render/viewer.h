#pragma once
/// \file
/// The interactive viewer: a GLFW window with an OpenGL 3.3 core view of the organ and a Dear
/// ImGui interface. The simulation runs in its own thread at a fixed rate
/// (interact::RealtimeLoop); the window draws its latest snapshot at up to 60 frames a second.
/// Polyscope-style use:
///
///     render::Viewer viewer;                   // options: size, title, rate, script...
///     viewer.set_model(std::move(vm));         // the model, its fixed nodes and name
///     return viewer.show();                    // until the window closes
///
/// Mouse: left-drag on the organ pushes or pulls it with a force proportional to the drag (the
/// reference paper's interaction); hold Shift when releasing to pin the force, so several act at
/// once; release without Shift and the organ returns to rest. Left-drag elsewhere orbits,
/// right- or middle-drag pans, the wheel zooms. In tool-tip mode a sphere follows the mouse while
/// the left button is held and the wheel pushes it in or pulls it out.
/// Keys: R reset, Space pause, C release pinned forces, T toggle tool-tip mode, S screenshot.

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "lamina/core/progress.h"
#include "lamina/interact/tools.h"
#include "lamina/model/model.h"
#include "lamina/model/surface_support.h"
#include "lamina/sim/simulation.h"

namespace lamina::render {

/// A model to view, with what the viewer cannot guess.
struct ViewerModel {
  Model model;
  std::vector<int32_t> fixed;     ///< nodes held at rest (the boundary)
  model::SurfaceSupport support;  ///< nodes held elastically (the body around the organ)
  /// The material as resolved for this model (a rebuilt model's damping follows its own slowest
  /// vibration); unset: the viewer keeps the one it has.
  std::optional<sim::Material> material;
  std::string source;          ///< shown in the title bar and panels
  /// Forces acting from the start (pinned), e.g. a scene's tools: skin node and force in mN.
  std::vector<std::pair<int32_t, Eigen::Vector3d>> pinned;
  int32_t watched_node =
      -1;  ///< node whose displacement is plotted at first; -1 = the first pinned
};

/// Rebuilds the model with other layer counts or resolution (from the viewer's Model panel).
/// Runs on a worker thread; reports progress through `progress`.
using RebuildFn =
    std::function<ViewerModel(int32_t layers, int32_t skin_vertices, const ProgressFn& progress)>;

struct ViewerOptions {
  int width = 1400, height = 900;
  std::string title = "Lamina";
  double rate_hz = 1000.0;  ///< simulation steps per wall second; 0 = as fast as possible
  /// Drag force per mm of drag. Lower than the scene files' 0.05: a mouse drags 100 mm easily,
  /// and 1 N already dents the paper's K = 3 N/m model by about 20 mm.
  double gain_n_per_mm = 0.01;
  sim::Material material;  ///< start values of the panels
  sim::SolverOptions solver;
  interact::RoutingOptions routing;
  RebuildFn rebuild;  ///< empty: the Model panel cannot rebuild
  /// Scripted input (docs/viewer.md): a JSON file of timed mouse, key and screenshot events,
  /// fed through the same code as the real mouse. For tests, demos and recordings.
  std::string script;
  /// Where to write a JSON report when the window closes (frames, steps, achieved rate, largest
  /// displacement...); empty = none.
  std::string report;
};

/// Throws lamina::Error (kUnavailable) if no display can be reached (DISPLAY and WAYLAND_DISPLAY
/// unset), with a message suggesting `lamina render`. Cheap: call it before long work.
void check_display();

/// Reads and checks a scripted-input file without opening anything.
/// \note Throws lamina::Error (kInvalidInput) "PATH: events[i].key: problem".
void check_viewer_script(const std::string& path);

class Viewer {
 public:
  explicit Viewer(ViewerOptions options = {});
  ~Viewer();
  Viewer(const Viewer&) = delete;
  Viewer& operator=(const Viewer&) = delete;

  void set_model(ViewerModel model);

  /// Opens the window and runs until it is closed (or the script quits).
  /// @return 0
  /// \note Throws lamina::Error (kUnavailable) when there is no display ("use lamina render"),
  ///   and (kInvalidInput) for a malformed script.
  int show();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lamina::render
