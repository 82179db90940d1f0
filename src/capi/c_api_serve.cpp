// The C API's serve (include/lamina/c_api.h): `lamina serve` for a C program or an engine's
// plugin, through the library's network edge (include/lamina/net/serve.h).
#include "c_api_support.h"
#include "lamina/c_api.h"
#include "lamina/io/scene.h"
#include "lamina/io/scene_model.h"
#include "lamina/io/world_scene.h"
#include "lamina/net/serve.h"

using lamina::capi::guarded;

namespace {

lamina::net::ServeOptions library_options(const lamina_serve_options& c) {
  lamina::net::ServeOptions o;
  if (c.host) o.host = c.host;
  o.port = c.port;
  o.web = c.web != 0;
  if (c.web_host) o.web_host = c.web_host;
  o.web_port = c.web_port;
  if (c.web_token) o.web_token = c.web_token;
  o.self_signed = c.self_signed != 0;
  o.rate_hz = c.rate_hz;
  o.send_hz = c.send_hz;
  o.max_force_n = c.max_force_n;
  o.duration_s = c.duration_s;
  return o;
}

}  // namespace

void lamina_serve_options_default(lamina_serve_options* options) {
  if (options == nullptr) return;
  const lamina::net::ServeOptions o;
  *options = lamina_serve_options{.host = nullptr,
                                  .port = o.port,
                                  .web = 0,
                                  .web_host = nullptr,
                                  .web_port = o.web_port,
                                  .web_token = nullptr,
                                  .self_signed = 0,
                                  .rate_hz = o.rate_hz,
                                  .send_hz = o.send_hz,
                                  .max_force_n = o.max_force_n,
                                  .duration_s = o.duration_s};
}

lamina_status lamina_serve(const char* what, const lamina_serve_options* options,
                           const volatile int32_t* stop) {
  return guarded([&] {
    namespace io = lamina::io;
    namespace net = lamina::net;
    const std::string input = lamina::capi::need_text(what, "lamina_serve: what");
    const net::ServeOptions o =
        library_options(lamina::capi::need(options, "lamina_serve: options"));
    net::check_options(o);
    const net::KeepGoing keep_going = [stop] { return stop == nullptr || *stop == 0; };
    int code = 0;
    if (io::is_world_scene_file(input)) {
      net::Listening listening(o, /*igtl=*/true);
      const io::WorldScene scene = io::load_world_scene(input);
      std::unique_ptr<io::ReadyWorld> ready = io::make_ready_world(scene, io::ReadVolumeOptions{});
      code = net::serve_world(listening, std::move(ready->world), scene.dissections, o,
                              scene.source, keep_going);
    } else {
      io::Scene scene = io::scene_for(input);
      scene.tools.clear();  // the clients drive the tool
      scene.default_tool = false;
      net::Listening listening(o, /*igtl=*/true);
      const io::ReadyScene ready = io::make_ready_scene(scene);
      code = net::serve_organ(listening, io::make_scene_simulation(ready), ready.model,
                              ready.scene.routing, o, ready.source, keep_going);
    }
    if (code == static_cast<int>(lamina::ErrorKind::kUnstable))
      throw lamina::Error(lamina::ErrorKind::kUnstable,
                          input + ": the simulation blew up during the serve (see the log)");
  });
}
