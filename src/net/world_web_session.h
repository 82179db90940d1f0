#pragma once
/// \file
/// `lamina serve SCENE.json --web` of a world scene (docs/web.md, "A world"): the page draws
/// every body (world_stream.h), a mouse drag on any of them pushes or pulls it through the
/// world's loop, and the scene's graspers and blades play on its clock. A headset's hands act as
/// on one organ: a trigger drives the tool tip, which pushes whichever body it touches, a grip
/// closes the grasper on the body nearest it (world::WorldLoop::set_tool_tip, set_grasper), and
/// each frame carries the tissue's push on them for the controllers' vibration. Runs on the
/// serve loop's network thread, as the one-organ session does.

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
  void follow_cut();
  bool topology_moved_on() const;
  void hand(int client, const nlohmann::json& m);
  void release_tip();
  void release_grasper();

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
    bool pushing = false;  // its force set on the loop (a cut carries it)
  } drag_;
  struct Hand {
    int client = -1, hand = -1;
    uint32_t pose = 0;                              // the newest pose applied
    int64_t pose_step = 0;                          // the loop's step count when it was applied
    uint32_t reflected = 0;                         // the newest pose a frame has shown
    std::chrono::steady_clock::time_point pose_at;  // when the newest pose came in
  };
  Hand tip_hand_, grasp_hand_;
  interact::ToolTip tip_;
  bool grasp_missed_ = false;  // the last grasp found nothing (said once per grip)
  uint32_t frames_ = 0;
  std::chrono::steady_clock::time_point next_frame_;
  std::vector<double> encode_ms_, frame_kb_;
  std::vector<double> pose_to_frame_ms_;  // a pose's arrival to the first frame showing it
};

}  // namespace lamina::net::web
