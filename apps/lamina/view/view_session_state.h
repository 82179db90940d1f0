#pragma once
// The state of a `lamina view` session, shared by its files: view_session.cpp (life, the frame,
// the simulation), view_gestures.cpp (mouse and keys), view_panels.cpp (Dear ImGui),
// view_rebuild.cpp (the background rebuild) and view_report.cpp (report, screenshots, export).

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "lamina/geometry/plan_resection.h"
#include "lamina/model/model_territories.h"
#include "lamina/render/input.h"
#include "lamina/render/viewer.h"
#include "lamina/world/organ_loop.h"
#include "traced_stroke.h"
#include "view_script.h"
#include "view_session.h"

namespace lamina::cli {

using Clock = std::chrono::steady_clock;

enum class Gesture { kNone, kOrbit, kPan, kDrag, kTool, kGrasp, kScalpel, kPlane };

// A fixed-length history for the live plots.
struct History {
  static constexpr int kLength = 600;  // 10 s at 60 frames a second
  std::vector<float> values = std::vector<float>(kLength, 0.0f);
  int next = 0, count = 0;
  void push(float v) {
    values[next] = v;
    next = (next + 1) % kLength;
    count = std::min(count + 1, kLength);
  }
  float last() const { return count ? values[(next + kLength - 1) % kLength] : 0.0f; }
};

struct ViewSession::State {
  ViewOptions options;
  std::unique_ptr<ViewModel> vm;
  std::unique_ptr<world::OrganLoop> loop;
  world::LoopSnapshot snap;
  uint64_t shown_generation = ~uint64_t{0};  // the snapshot last sent to the engine

  // Live parameters (the panels edit these, then hand them to the loop).
  sim::Material material;
  sim::SolverOptions solver;
  interact::RoutingOptions routing;
  double last_volume_kpa = 1.0;  // what the volume term comes back at when ticked again
  double rate_hz = 1000.0;
  bool auto_rate = false;  // the rate follows the machine (ViewOptions::auto_rate)
  bool paused = false;
  std::string param_error;

  // Display.
  render::Style style;
  bool show_rings = true;
  bool show_legend = true;  ///< the organ and each structure named in its colour
  float arrow_mm_per_n = 60.0f;
  int inner_choice = 0, coloring_choice = 0;

  // Interaction.
  bool tool_mode = false;
  bool grasp_mode = false;  // a left press grasps the skin, the drag retracts it (G)
  Gesture gesture = Gesture::kNone;
  // The grasper's jaws, while closed: about forceps' width (a 4 mm radius takes one node of the
  // paper-size skin's 10 mm mesh and pulls a spike).
  interact::Jaws jaws{.radius_mm = 10.0};
  // The scalpel (K): a drag across the organ traces the blade's path on the skin; the release
  // cuts along it, the blade reaching scalpel_depth_mm along the view direction.
  bool scalpel_mode = false;
  double scalpel_depth_mm = 15.0;
  TracedStroke scalpel;        // the blade's path under the drag
  uint64_t model_version = 0;  // the loop's cut model adopted
  int64_t cuts = 0;
  bool reset_asked = false;  // R: the next change of model is the organ put back uncut
  std::vector<model::StructureCut> crossed;  // every structure the cuts in force crossed (marked)
  std::vector<size_t> crossed_before;        // per cut in force: crossed.size() before it
  std::string cut_message;                   // what the last cut did, or why it did nothing
  bool grasp_held = false;                   // closed and left holding (Shift+release); C opens it
  bool scene_grasp = false;  // the scene's grasper (ViewModel::grasper) is playing its pull
  double scene_grasp_since_s = -1.0;  // simulated time it closed at; -1 = to close
  int scene_grasp_refusals = 0;       // closes refused in a row (retried after a reset)
  Eigen::Vector2d press_pos = Eigen::Vector2d::Zero(), last_pos = Eigen::Vector2d::Zero();
  int32_t drag_node = -1;
  Eigen::Vector3d grab_point = Eigen::Vector3d::Zero();
  Eigen::Vector3d drag_force = Eigen::Vector3d::Zero();  // mN
  std::vector<interact::LiveForce> pinned, sent;
  interact::ToolTip tip;
  double tool_depth_mm = 0.0;
  int32_t watched = -1;
  std::string last_press;  // what the last left press did, and why

  // The resection plane (P, view_plan.cpp): placed over the organ, moved with the mouse, the plan
  // followed live; X resects along it.
  struct Plan {
    bool on = false, placed = false, resected = false;
    Eigen::Vector3d point = Eigen::Vector3d::Zero(), normal = Eigen::Vector3d::UnitX();
    Eigen::Vector3d grab = Eigen::Vector3d::Zero();  // where the press met the plane
    Eigen::Vector3d point_at_press = Eigen::Vector3d::Zero();
    Eigen::Vector3d normal_at_press = Eigen::Vector3d::UnitX();
    double size_mm = 200.0;  // the square drawn (and cut along)
    float margin_mm = 10.0f;
    int liver = 0;  // geometry::LiverCondition
    int keep = 0;   // the larger side, the front, the back
    bool dirty = true;
    uint64_t generation = ~uint64_t{0};  // the snapshot planned on
    double last_s = -1.0;                // when, in the session's seconds
    geometry::ResectionReport report;
    std::string error;
    int64_t updates = 0, moves = 0;
    std::vector<double> update_ms;
    std::vector<render::EmbeddedLook> looks;  // the structures' colours before the margins'
    bool awaiting_cut = false;  // X was pressed: the resected pieces go once the cut is in
    bool remnant_in_front = true;
    // The functional remnant's picture (view_plan_function.cpp): the model's territories, made
    // once per topology; per tree, the seed nearest each display-skin vertex at rest.
    bool territories = true;  // colour the skin by the portal territories
    model::ModelTerritories made;
    std::vector<std::vector<int32_t>> skin_seed;
    Eigen::Index skin_rows = -1;
    int64_t shaded_triangles = 0, territory_triangles = 0;  // drawn by the last plan
  } plan;
  // The boundary by rest position (a cut's copies keep their node's): the fixed nodes and the
  // supported ones with their stiffness, as the loop started; the remnant after X takes them.
  std::vector<Eigen::Vector3d> fixed_at;
  std::vector<std::pair<Eigen::Vector3d, double>> support_at;
  std::string plan_message;

  // Plots.
  History h_displacement, h_volume, h_step_us, h_rate;

  // Rebuild in the background.
  int rebuild_layers = 2, rebuild_vertices = 1284;
  std::thread rebuild_thread;
  std::atomic<bool> rebuilding{false};
  std::mutex rebuild_mutex;
  std::string rebuild_stage, rebuild_error;
  double rebuild_fraction = 0.0;
  std::unique_ptr<ViewModel> rebuilt;

  // Script, frames and report.
  ScriptPlayer script{{}};
  bool quit = false;
  bool started = false;
  int64_t frames = 0;
  double max_displacement_mm = 0.0, frame_seconds = 0.0;
  int64_t drags = 0, rebuilds = 0;
  // What the report says about real time and about the last drag: where the organ dented
  // most while it was dragged, and how far it was from rest 3 s (wall time) after the release.
  double min_real_time_factor = 0.0;  // over the run after its first second; 0 = not yet
  int frame_interval_us = 16667;      // the frame pacing: 60 Hz, slower while the loop is behind
  bool behind_seen = false;
  // Unstable simulations (sim::Instability) seen, the first one's reason and simulated time:
  // said on screen, in the log, in the report, and as exit code 5.
  int64_t unstable_events = 0;
  bool unstable_now = false;
  sim::Instability first_unstable = sim::Instability::kNone;
  double first_unstable_s = 0.0;
  double drag_peak_mm = 0.0;
  int32_t drag_peak_node = -1, last_drag_node = -1;
  // The last release, in simulated seconds, and the largest displacement 3 simulated seconds
  // later (-1: not yet): the simulation's own clock, so that a slow machine measures the same.
  double released_at_sim_s = -1.0, settle_3s_mm = -1.0;
  double wait_from_sim_s = 0.0;  // the simulated time a script's "simulated" wait began at
  Clock::time_point start_time = Clock::now();  // start()'s clock, which scripts also follow
  std::vector<std::string> screenshots;
  std::string status;
  std::string window_shot;  // taken once the frame (panels included) is drawn
  bool view_shot = false;   // S or the Save panel: the 3-D view, once this frame is set up
  char screenshot_path[512] = "";
  char export_path[512] = "lamina_skin.obj";

  double seconds() const {
    return std::chrono::duration<double>(Clock::now() - start_time).count();
  }

  // view_session.cpp
  void start_loop();
  void push_parameters();
  void update_forces();
  void play_scene_grasper();
  void adopt_cut();  // the loop's cut model, once it publishes one
  void on_frame();
  void show_state();  // positions, style and overlays to the engine
  // view_gestures.cpp
  void handle_key(const std::string& key);
  void handle_mouse(const render::Input& in);
  void start_left_gesture(const render::Input& in);
  void cut_along_path();
  // view_plan.cpp
  void toggle_plan();
  void update_plan();  // each frame: the plan again when the plane or the organ moved
  // The functional remnant on the skin at x: lost tissue shaded, territories coloured.
  void show_function(const Eigen::MatrixX3d& x, const std::vector<const Eigen::MatrixX3d*>& ex);
  void hide_function();
  void function_panel();
  bool press_on_plane(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction);
  void move_plane(const Eigen::Vector2d& drag_px, bool turn);
  void resect_plan();
  void take_away_resected();  // after X's cut: the remnant alone, simulated on
  void plan_panel();
  nlohmann::json plan_json() const;
  // view_panels.cpp
  void panels();
  void state_lines(const Model& m);  // the organ's state, and whether it keeps real time
  void interaction_panel();
  bool routing_widgets(const Model& m);  // true when a parameter changed
  void display_panel(const Model& m);
  void model_panel();
  void plots_window();
  void embedded_panel(const Model& m);  // the Display panel's embedded surfaces
  /// The camera that frames the organ right of the left panel (its first view, "Fit view").
  void frame_organ(const Model& m) const;
  void record_plots();
  // view_rebuild.cpp
  void start_rebuild();
  void adopt_rebuilt();
  bool rebuild_pending();                     // building, or built and not yet in use
  bool waiting_for(const std::string& what);  // a script's "wait" still under way
  // view_report.cpp
  void watch_real_time_and_drag(double t);
  void follow_the_machine(double t);  // auto_rate: the rate it keeps, each measured second
  void watch_instability();
  nlohmann::json report() const;
  void write_report() const;
  void save_screenshot(std::string path);
  void save_window_screenshot(const std::string& path);
  void export_skin(const std::string& path);
  void act_on_script(double t);
};

}  // namespace lamina::cli
