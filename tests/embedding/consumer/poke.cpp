// docs/embedding.md's first example: build the phantom liver, poke it with the default scene's
// tool as `lamina run` does, and render the dent without a window. Built against an installed
// Lamina by tests/embedding/consumer_test.cmake.
#include <cstdio>

#include "lamina/interact/run_tools.h"
#include "lamina/io/scene_model.h"
#include "lamina/render/camera.h"
#include "lamina/render/offscreen.h"
#include "lamina/render/renderer.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: poke OUTPUT.png\n");
    return 2;
  }
  // The default scene: a physical liver (here the built-in phantom; a scene's "input" names a
  // mask file) held at its back, one tool pushing 0.4 N for 1 s. make_ready_scene builds the
  // model and prepares the scene against it as every Lamina command does.
  const lamina::io::ReadyScene ready = lamina::io::make_ready_scene(lamina::io::Scene{});
  const lamina::Model& model = *ready.model;
  lamina::sim::Simulation sim = lamina::io::make_scene_simulation(ready);
  lamina::interact::ToolDriver tools = lamina::io::make_tool_driver(ready.scene);
  const lamina::interact::ToolRun run = lamina::interact::run_tools(sim, tools, 0.5, false);
  std::printf("%d nodes; after %lld steps (%.2f s) the tool has moved the tissue %.2f mm\n",
              model.node_count(), static_cast<long long>(run.steps), sim.time_s,
              run.last.max_displacement_mm);

  // A picture of the dent (EGL, no display needed).
  lamina::render::HeadlessContext context;
  lamina::render::Renderer renderer;
  lamina::render::Frame frame{.model = &model, .x = &sim.x};
  const lamina::render::Camera camera = lamina::render::fit_camera(model);
  lamina::render::write_png(lamina::render::render_image(renderer, frame, camera, 640, 480),
                            argv[1]);
  return run.last.max_displacement_mm > 0.5 ? 0 : 1;
}
