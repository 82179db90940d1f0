#pragma once
/// \file
/// `lamina serve --web`'s side of the serve loop (docs/web.md): the web server, the stream laid
/// out for the loop's model, and what a browser's messages do to the simulation. Runs on the
/// serve loop's network thread, beside the OpenIGTLink server, and shares its tools: the tool tip
/// and the grasper are held by one client at a time, of either kind (web clients' ids start at
/// kWebClientBase, so the two never clash).

#include <chrono>
#include <deque>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "lamina/world/organ_loop.h"
#include "web_server.h"
#include "web_stream.h"

namespace lamina::net::web {

inline constexpr int kWebClientBase = 1 << 20;

/// The tools the serve loop's clients share, and who holds each (-1: nobody).
struct SharedTools {
  interact::ToolTip& tip;
  int& tip_client;
  int& grasper_client;
};

struct SessionOptions {
  double frame_hz = 60.0;       ///< frames per second to each browser
  double gain_n_per_mm = 0.01;  ///< the desktop drag's force per mm dragged (lamina view's)
  /// A controller's jaws take the skin within this distance (lamina view's grasper: a hand in a
  /// headset is less steady than a tracked instrument, OpenIGTLink's --grasper-radius).
  double grasp_radius_mm = 10.0;
  /// A world's tool tip (its radius, coupling and limits: the serve's); the one-organ session
  /// shares OpenIGTLink's (SharedTools).
  interact::ToolTip tip;
  nlohmann::json hello_fields;  ///< joins every hello (the tools' limits, the rate)
  /// Answers a page's "plan" message (web_plan.h's plan_reply with its cache: lamina serve's);
  /// empty: the page is told this server does not plan. Given here so that the session's own
  /// code does not pull in the planner (the TSan harness builds the session alone).
  std::function<std::string(const Model& model, uint64_t model_version, const Eigen::MatrixX3d& x,
                            const Eigen::Vector3d& point, const Eigen::Vector3d& normal)>
      plan;
};

class Session {
 public:
  /// `server` is made (and listening) before the model is built, so that a port in use fails
  /// at once.
  Session(std::unique_ptr<Server> server, SessionOptions options, world::OrganLoop& loop,
          SharedTools tools, std::shared_ptr<const Model> model);

  const Server& server() const { return *server_; }

  /// Runs the network's ready work, then sends a frame if one is due; returns how long the
  /// serve loop may wait before calling again, s.
  double poll();

  /// A tool held by a web client has been let go by the serve loop (its OpenIGTLink client took
  /// it): forget its holder's hand.
  void tools_changed();

  /// One line: frames sent, their median size, the encoding's median time.
  void log_summary() const;

 private:
  struct Hand {
    int client = -1, hand = -1;
    uint32_t pose = 0;                              // the newest pose applied
    int64_t pose_step = 0;                          // the loop's step count when it was applied
    uint32_t reflected = 0;                         // the newest pose a frame has shown
    std::chrono::steady_clock::time_point pose_at;  // when the newest pose came in
  };

  void opened(int client);
  void handle(int client, const std::string& peer, const std::string& text);
  void closed(int client);
  void send_frame();
  void event(int client, const std::string& text, bool bad);
  void release_tip();
  void release_grasper();

  std::unique_ptr<Server> server_;
  SessionOptions options_;
  world::OrganLoop& loop_;
  SharedTools tools_;
  std::unique_ptr<WebStream> stream_;
  uint64_t stream_version_ = 0;
  int64_t cuts_seen_ = 0;
  world::LoopSnapshot snap_;
  Hand tip_hand_, grasp_hand_;
  bool grasp_missed_ = false;  // the last grasp found nothing (said once per press)
  int drag_client_ = -1;
  int32_t drag_node_ = -1;
  uint64_t drag_version_ = 0;  // the model version drag_node_ is a node of
  void follow_drag();          // drag_node_ carried through a change of model, or the drag ended
  uint32_t frames_ = 0;
  std::chrono::steady_clock::time_point next_frame_;
  std::vector<double> encode_ms_, frame_kb_;
  std::vector<double> pose_to_frame_ms_;  // a pose's arrival to the first frame showing it
};

}  // namespace lamina::net::web
