#pragma once
/// \file
/// What a scene runs on: the segmentation or saved model it names, made into a Model. Shared by
/// the command-line tool, the Python module and the C API, so that a scene gives the same
/// model wherever it is run.

#include <string>

#include "lamina/core/progress.h"
#include "lamina/io/label_volume_io.h"
#include "lamina/io/scene.h"
#include "lamina/model/model.h"

namespace lamina::io {

/// The segmentation named by `input`: the built-in phantom for kScenePhantom ("phantom"), else a
/// mask file or a DICOM folder read with `options`.
/// \note Throws lamina::Error (kInvalidInput) as read_label_volume().
LabelVolume read_input(const std::string& input, const ReadVolumeOptions& options = {});

/// A scene's model and what it was made from.
struct SceneModel {
  Model model;
  std::string source;  ///< the mask's or the saved model's path, or the phantom's name
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

}  // namespace lamina::io
