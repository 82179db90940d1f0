#pragma once
/// \file
/// `lamina serve SCENE.json --web` of a world scene (docs/web.md, "A world"): the page draws
/// every body (world_stream.h), a mouse drag on any of them pushes or pulls it through the
/// world's loop, and the scene's graspers and blades play on its clock. Runs on the serve loop's
/// network thread, as the one-organ session does. The headset's hands act on one organ only: in
/// a world the page is told so, once, and its hands do nothing.

#include <chrono>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "lamina/world/world_loop.h"
#include "web_server.h"
#include "web_session.h"
#include "web_stream.h"

namespace lamina::net::web {

class WorldSession {
 public:
  /// `server` is made (and listening) before the world is built.
  WorldSession(std::unique_ptr<Server> server, SessionOptions options, world::WorldLoop& loop);

  const Server& server() const { return *server_; }
  /// The network's ready work, then a frame if one is due; how long the caller may wait, s.
  double poll();
  /// One line: frames sent, their median size and encoding time.
  void log_summary() const;

 private:
  void opened(int client);
  void handle(int client, const std::string& text);
  void closed(int client);
  void send_frame();
  void event(int client, const std::string& text);
  void release_drag();

  std::unique_ptr<Server> server_;
  SessionOptions options_;
  world::WorldLoop& loop_;
  std::unique_ptr<WebStream> stream_;
  world::WorldSnapshot snap_;
  Eigen::MatrixX3d stacked_;  // the bodies' positions as the stream numbers them
  struct Drag {
    int client = -1;
    world::BodyId body;
    uint32_t topology = 0;
    int32_t node = -1;
  } drag_;
  std::set<int> told_hands_;  // clients told that hands do nothing in a world
  uint32_t frames_ = 0;
  std::chrono::steady_clock::time_point next_frame_;
  std::vector<double> encode_ms_, frame_kb_;
};

}  // namespace lamina::net::web
