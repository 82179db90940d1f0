#include "lamina/io/scene_model.h"

#include <algorithm>

#include "lamina/core/clock.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/geometry/make_phantom.h"
#include "lamina/io/model_file.h"
#include "lamina/model/build_model.h"
#include "lamina/model/compute_rings.h"

namespace lamina::io {
LabelVolume read_input(const std::string& input, const ReadVolumeOptions& options) {
  return input == kScenePhantom ? geometry::make_phantom() : read_label_volume(input, options);
}

SceneModel make_scene_model(const Scene& scene, const ReadVolumeOptions& read_options,
                            const ProgressFn& progress) {
  SceneModel out;
  auto t = Clock::now();
  // Rings must reach as far as the routing spreads force (RoutingOptions::locality).
  const int32_t locality = std::max(scene.build.locality, scene.routing.locality);
  if (!scene.model_path.empty()) {
    out.source = scene.model_path;
    out.model = load_model(scene.model_path);
    out.stage_seconds.emplace_back("read", seconds_since(t));
    t = Clock::now();
    if (scene.density_given) {
      // Lumped masses are proportional to the density they were computed with.
      const double scale = scene.build.density_kg_per_mm3 / out.model.density_kg_per_mm3;
      for (double& m : out.model.mass_kg) m *= scale;
      out.model.density_kg_per_mm3 = scene.build.density_kg_per_mm3;
    }
    out.model.rings = model::compute_rings(out.model, std::max(out.model.rings.locality, locality));
    out.stage_seconds.emplace_back("rings", seconds_since(t));
    return out;
  }
  const LabelVolume volume = read_input(scene.input, read_options);
  out.stage_seconds.emplace_back("read", seconds_since(t));
  out.source = volume.source;
  model::BuildOptions options = scene.build;
  options.locality = locality;
  model::BuildResult built = model::build_model(volume, options, progress);
  out.model = std::move(built.model);
  for (const auto& stage : built.report.stage_seconds) out.stage_seconds.push_back(stage);
  return out;
}

Scene scene_for(const std::string& what, bool paper) {
  if (what.ends_with(".json")) {
    if (paper)
      throw invalid_input(
          "--paper", "cannot be given with a scene file (" + what +
                         "): the scene sets the model and material; see examples/paper_*.json");
    return load_scene(what);
  }
  Scene scene = paper ? paper_scene() : Scene{};
  scene.source = what;
  if (what.ends_with(".vtu")) {
    scene.input.clear();
    scene.model_path = what;
  } else {
    scene.input = what;
  }
  return scene;
}

ReadyScene make_ready_scene(const Scene& scene, const ReadVolumeOptions& read_options,
                            const ProgressFn& progress) {
  return make_ready_scene(scene, make_scene_model(scene, read_options, progress));
}

ReadyScene make_ready_scene(const Scene& scene, SceneModel built) {
  ReadyScene r;
  r.parsed = scene;
  r.scene = scene;
  r.model = std::make_shared<Model>(std::move(built.model));
  r.source = std::move(built.source);
  r.stage_seconds = std::move(built.stage_seconds);
  const auto t = Clock::now();
  r.setup = prepare_scene(r.scene, *r.model);
  r.stage_seconds.emplace_back("prepare_scene", seconds_since(t));
  return r;
}

ReadyScene rebuild_ready_scene(const Scene& parsed, int32_t layers, int32_t skin_vertices,
                               const ReadVolumeOptions& read_options, const ProgressFn& progress) {
  Scene s = parsed;
  s.build.layers = layers;
  s.build.skin_vertices = skin_vertices;
  s.default_tool = true;
  s.tools.clear();
  ReadyScene r = make_ready_scene(s, read_options, progress);
  r.parsed = parsed;  // a later rebuild starts from the scene as given
  return r;
}

sim::Simulation make_scene_simulation(const ReadyScene& ready) {
  return make_scene_simulation(ready.scene, *ready.model, ready.setup);
}

void warn_scalpels_ignored(const Scene& scene) {
  if (!scene.scalpels.empty())
    log::warn("{}: its {} scalpel(s) are ignored here: only `lamina run` cuts with them yet",
              scene.source, scene.scalpels.size());
}

interact::ToolDriver make_tool_driver(const Scene& scene, bool warn_scalpels) {
  if (warn_scalpels) warn_scalpels_ignored(scene);
  interact::ToolDriver driver;
  driver.tools = scene.tools;
  driver.routing = scene.routing;
  return driver;
}

}  // namespace lamina::io
