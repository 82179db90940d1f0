#pragma once
/// \file
/// What a scene runs on: the segmentation or saved model it names, made into a Model. Shared by
/// the command-line tool, the Python module and the C API, so that a scene gives the same
/// model wherever it is run.

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "lamina/core/progress.h"
#include "lamina/interact/tools.h"
#include "lamina/io/label_volume_io.h"
#include "lamina/io/scene.h"
#include "lamina/model/model.h"
#include "lamina/sim/simulation.h"

namespace lamina::io {

/// The segmentation named by `input`: the built-in phantom for kScenePhantom ("phantom"), else a
/// mask file or a DICOM folder read with `options`.
/// \note Throws lamina::Error (kInvalidInput) as read_label_volume().
LabelVolume read_input(const std::string& input, const ReadVolumeOptions& options = {});

/// A scene's model and what it was made from.
struct SceneModel {
  Model model;
  std::string source;  ///< the mask's or the saved model's path, or the phantom's name
  /// Wall seconds per stage, in order: "read" (the mask or the model file), then the build's
  /// own stages (BuildReport::stage_seconds) or "rings" for a loaded model.
  std::vector<std::pair<std::string, double>> stage_seconds{};
};

/// Builds the scene's model from its input with scene.build, or loads scene.model_path (its
/// masses rescaled when the scene gives another density), with rings as far as the scene's
/// routing spreads force.
/// \note Throws lamina::Error (kInvalidInput) for an unreadable input or model.
SceneModel make_scene_model(const Scene& scene, const ReadVolumeOptions& read_options = {},
                            const ProgressFn& progress = {});

/// What one argument names, as a scene: a SCENE.json is loaded; a .vtu model, a mask file, a
/// DICOM folder or "phantom" becomes the default scene on that model (the reference paper's
/// constants when `paper`).
/// \note Throws lamina::Error (kInvalidInput) for a scene file together with `paper`, and as
///   load_scene().
Scene scene_for(const std::string& what, bool paper = false);

/// A scene made ready to simulate: its model made, the scene's defaults resolved against it and
/// checked, its fixed and supported nodes found and its material resolved. The one setup every
/// command, the viewer (and its rebuilds), the soak, the server and the bindings start from, so
/// that a scene runs the same wherever it is run.
struct ReadyScene {
  Scene parsed;  ///< the scene as given, before it was resolved (a rebuild starts from it)
  Scene scene;   ///< resolved: default tools and boundary made concrete, material decided
  /// Shared, because simulations keep a reference to their model: it must outlive them.
  /// resolve_material() may have replaced its spring constants.
  std::shared_ptr<Model> model;
  std::string source;  ///< what the model was built or loaded from
  SceneSetup setup;    ///< fixed and supported nodes, what resolve_material() decided
  /// Wall seconds per stage: SceneModel's, then "prepare_scene" (support, material, the slowest
  /// vibration for a damping ratio).
  std::vector<std::pair<std::string, double>> stage_seconds{};
};

/// make_scene_model(), then make_ready_scene() on the model.
/// \note Throws lamina::Error (kInvalidInput) as make_scene_model() and prepare_scene().
ReadyScene make_ready_scene(const Scene& scene, const ReadVolumeOptions& read_options = {},
                            const ProgressFn& progress = {});

/// Prepares `scene` against a model already made (prepare_scene()).
/// \note Throws lamina::Error (kInvalidInput) as prepare_scene().
ReadyScene make_ready_scene(const Scene& scene, SceneModel built);

/// The scene `parsed` rebuilt at another resolution (the viewer's Model panel): `layers` layers
/// and about `skin_vertices` skin vertices, prepared as make_ready_scene() prepares any scene, so
/// the material is resolved again (a damping ratio follows the new model's slowest vibration).
/// The scene's own tools are dropped for the default poke: their vertices were the old model's.
/// \note Throws lamina::Error (kInvalidInput) as make_ready_scene().
ReadyScene rebuild_ready_scene(const Scene& parsed, int32_t layers, int32_t skin_vertices,
                               const ReadVolumeOptions& read_options = {},
                               const ProgressFn& progress = {});

/// A simulation of a ready scene at rest: its material and solver, its nodes fixed and
/// supported. It refers to `ready.model`, which must outlive it.
sim::Simulation make_scene_simulation(const ReadyScene& ready);

/// A tool driver with the scene's tools and routing. A scene's scalpels are not tools it drives:
/// with `warn_scalpels`, warn_scalpels_ignored() says so (`lamina run`, which cuts with them,
/// passes false).
interact::ToolDriver make_tool_driver(const Scene& scene, bool warn_scalpels = true);

/// Warns that the scene's scalpels are ignored (for the commands and bindings that do not cut
/// yet; only `lamina run` plays them). Nothing when it has none.
void warn_scalpels_ignored(const Scene& scene);

}  // namespace lamina::io
