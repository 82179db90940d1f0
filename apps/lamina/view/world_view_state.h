#pragma once
// The world view session's state (world_view.h), shared by its files: world_view.cpp (its life,
// frame, script and gestures) and world_view_panel.cpp (the panel, the drawing and the report).
#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "lamina/core/clock.h"
#include "lamina/model/structure_colors.h"
#include "lamina/render/viewer.h"
#include "lamina/world/world_loop.h"
#include "traced_stroke.h"
#include "view_script.h"
#include "world_view.h"

namespace lamina::cli {

struct WorldViewSession::State {
  WorldViewOptions options;
  io::WorldScene scene;
  std::unique_ptr<io::ReadyWorld> ready;  // until start() hands its world to the loop
  std::unique_ptr<world::WorldLoop> loop;
  world::WorldSnapshot snap;
  ScriptPlayer script{{}};
  Clock::time_point start_time = Clock::now();
  bool started = false, quit = false, paused = false, dissect_mode = false, scalpel_mode = false,
       grasp_mode = false;
  // A scalpel drag (K) cuts the bodies' tissue this deep along the view direction, mm.
  double scalpel_depth_mm = 15.0;
  double rate_hz = 1000.0;
  bool auto_rate = false;
  uint64_t shown_generation = ~uint64_t{0};
  // The panel's "Body parameters": the body chosen (a snapshot index), the volume term's last
  // value and why the loop refused the last change, if it did.
  int param_body = 0;
  double last_volume_kpa = 1.0;
  std::string param_error;

  // Gestures.
  enum class Gesture { kNone, kOrbit, kPan, kDrag, kDissect, kScalpel, kGrasp };
  Gesture gesture = Gesture::kNone;
  Eigen::Vector2d last_pos = Eigen::Vector2d::Zero(), press_pos = Eigen::Vector2d::Zero();
  // A force on a body: its handle and topology generation (what the loop checks), its node.
  struct Force {
    world::BodyId body;
    uint32_t topology = 0;
    interact::LiveForce force;
  };
  std::optional<Force> drag;  // the drag in progress
  Eigen::Vector3d grab_point = Eigen::Vector3d::Zero();
  // G: a press on a body closes the grasper's jaws there (world::WorldLoop::set_grasper), the
  // drag carries them in the plane facing the eye, release opens them (Shift keeps them shut).
  bool grasp_held = false;
  int32_t grasps = 0;
  double grasp_radius_mm = 4.0;                        // the jaws' reach on the body pressed
  std::vector<Force> pinned;                           // Shift-released drags
  std::vector<std::vector<interact::LiveForce>> sent;  // per snapshot body: what the loop has
  std::vector<uint32_t> seen_topology;  // per snapshot body: its numbering the forces are on
  TracedStroke stroke;                  // a dissection's or a scalpel's path under the drag

  // What the session saw, for the panel and the report.
  int64_t frames = 0;
  int32_t drags = 0, strokes = 0, scalpel_strokes = 0;
  std::vector<double> max_displacement_mm, max_penetration_mm;  // per body
  double min_real_time_factor = 1.0;
  bool behind_seen = false;
  int32_t unstable_events = 0;
  bool unstable_seen = false;  // the current instability was counted
  std::string first_unstable;  // "body 'NAME' at t = ...: reason"
  double contact_share_sum = 0.0;
  int64_t contact_share_frames = 0;
  std::string last_press, status;
  std::vector<std::string> screenshots;
  std::string window_shot;
  int32_t frame_interval_us = 16667;

  double seconds() const { return seconds_since(start_time); }
  void on_frame();
  void act_on_script(double t);
  void handle_key(const std::string& key);
  void handle_mouse(const render::Input& in);
  void start_left_gesture(const render::Input& in);
  void send_forces();
  void forget_renumbered();
  void dissect_along_stroke();
  void cut_along_stroke();
  void start_grasp(const world::BodyView& body, int32_t node, const std::string& where);
  void watch(double t);    // real time, instability, the largest displacements
  void panel();            // world_view_panel.cpp
  void body_parameters();  // the panel's: one body's material and solver, live
  void show();             // positions and overlays to the engine
  void save_screenshot(const std::string& path, bool with_ui);
  nlohmann::json report() const;
};

}  // namespace lamina::cli
