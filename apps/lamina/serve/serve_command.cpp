// `lamina serve`: the simulation as an OpenIGTLink server, the way 3D Slicer's OpenIGTLinkIF
// connects to one (docs/openigtlink.md), and with --web the page for a browser or a headset
// (docs/web.md). The command reads the scene and builds it; the serving is the library's
// (include/lamina/net/serve.h), which the Python module and the C API call too.
#include <atomic>
#include <csignal>

#include "commands.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/io/scene.h"
#include "lamina/io/world_scene.h"
#include "lamina/net/serve.h"

namespace lamina::cli {
namespace {

std::atomic<bool> stop_requested{false};
void request_stop(int) {
  stop_requested = true;
}

// Ctrl-C and SIGTERM end the serve loop, which then stops the simulation and logs its summary.
void install_stop_signals() {
  struct sigaction action {};
  action.sa_handler = request_stop;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

int serve_world_scene(const ServeArgs& a) {
  if (a.paper)
    throw invalid_input("--paper", "cannot be given with a world scene (" + a.what + ")");
  net::Listening listening(a, /*igtl=*/true);  // a port in use fails at once
  install_stop_signals();
  const io::WorldScene scene = io::load_world_scene(a.what);
  std::unique_ptr<io::ReadyWorld> ready =
      io::make_ready_world(scene, volume_read_options, stderr_progress(a.verbose));
  return net::serve_world(listening, std::move(ready->world), scene.dissections, a, scene.source,
                          [] { return !stop_requested; });
}

}  // namespace

int run_serve(const ServeArgs& a) {
  net::check_options(a);
  if (io::is_world_scene_file(a.what)) return serve_world_scene(a);
  io::Scene scene = io::scene_for(a.what, a.paper);
  // The tool comes over the network; a scene's own tools would push on their own.
  if (!scene.tools.empty())
    log::info("{}: its {} tools are not used: the tool is driven over OpenIGTLink", scene.source,
              scene.tools.size());
  scene.tools.clear();
  scene.default_tool = false;
  // Listening first: a port in use fails before the model is built. Clients that connect
  // meanwhile wait in the listen queue.
  net::Listening listening(a, /*igtl=*/true);
  const io::ReadyScene ready =
      io::make_ready_scene(scene, volume_read_options, stderr_progress(a.verbose));
  io::warn_scalpels_ignored(ready.scene);
  install_stop_signals();
  return net::serve_organ(listening, io::make_scene_simulation(ready), ready.model,
                          ready.scene.routing, a, ready.source, [] { return !stop_requested; });
}

}  // namespace lamina::cli
