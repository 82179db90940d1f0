#pragma once
// The hands over OpenIGTLink (docs/openigtlink.md): what a pose of the tool, the grasper or the
// scalpel does, for one organ's loop (world::OrganLoop) and a world's (world::WorldLoop)
// alike, both of which take a tool tip, a grasper's jaws and a blade's cut. The sessions
// (igtl_session.h, world_igtl_session.h) add what each streams.
#include <fmt/format.h>

#include <limits>
#include <set>
#include <string>
#include <utility>

#include "igtl_server.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/net/serve.h"
#include "scalpel_stroke.h"
#include "serve_clock.h"

namespace lamina::net {

template <class Loop>
class IgtlHands {
 public:
  IgtlHands(const ServeOptions& a, Loop& loop, igtlink::Frame frame, ServeClock::time_point start)
      : a_(a), loop_(loop), frame_(frame), start_(start) {
    tip.radius_mm = a.tip_radius_mm;
    tip.stiffness_n_per_m = a.tip_stiffness_n_per_m;
    tip.max_force_n = a.max_force_n;
  }

  /// The scalpel's device: its poses trace a stroke, which cuts at "Up", a pause or the
  /// client's going; "Undo" takes the last cut back (both loops keep their last cuts to undo).
  /// False: not the scalpel's.
  bool scalpel_message(const igtlink::Message& msg) {
    const std::string& type = msg.header.type;
    const std::string& device = msg.header.device;
    if (a_.scalpel_device.empty()) return false;
    if (device == a_.scalpel_device + "Undo") {
      log::info("OpenIGTLink client {}: {} '{}' takes the last cut back", msg.peer, type, device);
      loop_.undo_cut();
    } else if (device == a_.scalpel_device + "Up") {
      if (stroke.client >= 0) log::info("{}", finish_stroke());
    } else if (device == a_.scalpel_device && (type == "TRANSFORM" || type == "POSITION")) {
      const igtlink::Pose pose = igtlink::read_pose(type, msg.content, msg.size);
      if (stroke.client >= 0 && stroke.client != msg.client)
        log::info("{}", finish_stroke());  // another hand's stroke
      if (stroke.client < 0)
        log::info("OpenIGTLink client {}: {} '{}' begins a scalpel stroke", msg.peer, type, device);
      stroke.add(msg.client, igtlink::change_frame(pose.position, frame_),
                 igtlink::change_frame(pose.z_axis, frame_), seconds(ServeClock::now() - start_));
    } else {
      return false;
    }
    return true;
  }

  /// The grasper's device: a pose closes its jaws there (or moves what they hold), "Open" lets
  /// go. False: not the grasper's.
  bool grasper_message(const igtlink::Message& msg) {
    const std::string& type = msg.header.type;
    if (a_.grasper_device.empty()) return false;
    if (msg.header.device == a_.grasper_device + "Open") {
      open_grasper(fmt::format("client {} sent {} '{}'", msg.peer, type, msg.header.device));
      return true;
    }
    if (msg.header.device != a_.grasper_device || (type != "TRANSFORM" && type != "POSITION"))
      return false;
    const interact::Jaws jaws{.center_mm = igtlink::change_frame(
                                  igtlink::read_position(type, msg.content, msg.size), frame_),
                              .radius_mm = a_.grasper_radius_mm};
    try {
      loop_.set_grasper(jaws);
    } catch (const Error& e) {  // nothing under the jaws: said, and nothing held
      if (noted.insert({msg.client, "grasp-miss"}).second)
        log::warn("OpenIGTLink client {}: {} (further misses are not logged)", msg.peer, e.what());
      return true;
    }
    if (grasper_client != msg.client)
      log::info("OpenIGTLink client {}: {} '{}' closes the grasper's jaws", msg.peer, type,
                msg.header.device);
    grasper_client = msg.client;
    return true;
  }

  /// Any other pose drives the tool tip (the tool_device's only, when given).
  void tool_pose(const igtlink::Message& msg) {
    const std::string& type = msg.header.type;
    const Eigen::Vector3d p = igtlink::read_position(type, msg.content, msg.size);
    if (!a_.tool_device.empty() && msg.header.device != a_.tool_device) {
      if (noted.insert({msg.client, type + msg.header.device}).second)
        log::info("OpenIGTLink client {}: {} '{}' is not the tool (--tool-device {}); skipped",
                  msg.peer, type, msg.header.device, a_.tool_device);
      return;
    }
    ++poses;
    if (tool_client != msg.client)
      log::info("OpenIGTLink client {}: {} '{}' drives the tool tip", msg.peer, type,
                msg.header.device);
    tool_client = msg.client;
    tip.center_mm = igtlink::change_frame(p, frame_);
    tip.active = true;
    loop_.set_tool_tip(tip);
  }

  /// A message of a type the server does not use: skipped, as the protocol has a receiver do,
  /// and logged once per client and type.
  void skip(const igtlink::Message& msg) {
    if (noted.insert({msg.client, msg.header.type}).second)
      log::info(
          "OpenIGTLink client {}: skipped {} '{}' (a type lamina serve does not use; further "
          "ones are skipped silently)",
          msg.peer, msg.header.type, msg.header.device);
  }

  void open_grasper(const std::string& why) {
    if (grasper_client < 0) return;
    grasper_client = -1;
    loop_.set_grasper(std::nullopt);
    log::info("the grasper opens: {}", why);
  }

  /// A client has gone: what it held is let go, its stroke cuts.
  void closed(int client) {
    std::erase_if(noted, [&](const auto& n) { return n.first == client; });
    if (client == grasper_client) open_grasper("its client has gone");
    if (client == stroke.client) log::info("{}", finish_stroke());
    if (client != tool_client) return;
    tool_client = -1;
    tip.active = false;
    loop_.set_tool_tip(tip);
    log::info("the tool tip is released: its client has gone");
  }

  /// A stroke whose poses paused past scalpel_pause_s cuts; how long the server may wait before
  /// the one under way would (s; large: none).
  double finish_paused_stroke(double now_s) {
    if (stroke.client >= 0 && now_s - stroke.last_pose_s >= a_.scalpel_pause_s)
      log::info("{} (its poses paused)", finish_stroke());
    return stroke.client >= 0 ? stroke.last_pose_s + a_.scalpel_pause_s - now_s
                              : std::numeric_limits<double>::infinity();
  }

  std::string finish_stroke() {
    return stroke.finish([this](std::vector<Eigen::Vector3d> top, const Eigen::Vector3d& axis,
                                double depth) { loop_.cut(std::move(top), axis, depth); },
                         a_.scalpel_depth_mm);
  }

  interact::ToolTip tip;
  int tool_client = -1;     ///< whose pose the tip follows
  int grasper_client = -1;  ///< whose pose the grasper follows (its jaws closed)
  int64_t poses = 0;
  ScalpelStroke stroke;
  std::set<std::pair<int, std::string>> noted;  ///< (client, what) already logged as skipped

 private:
  const ServeOptions& a_;
  Loop& loop_;
  igtlink::Frame frame_;
  ServeClock::time_point start_;
};

}  // namespace lamina::net
