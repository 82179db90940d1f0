#include "lamina/render/viewer.h"

#include <epoxy/gl.h>
// epoxy first: GLFW must not pull in another GL header.
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <fmt/format.h>
#include <imgui.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "lamina/core/atomic_file.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/interact/pick.h"
#include "lamina/interact/realtime_loop.h"
#include "lamina/io/mesh_file.h"
#include "lamina/model/summarize_model.h"
#include "lamina/render/camera.h"
#include "lamina/render/offscreen.h"
#include "lamina/render/renderer.h"
#include "viewer_script.h"

namespace lamina::render {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// The mouse and modifier state one frame sees, from GLFW or from the script.
struct Input {
  Eigen::Vector2d pos = Eigen::Vector2d::Zero();  // window pixels, origin top left
  bool buttons[3] = {false, false, false};        // left, right, middle
  bool shift = false;
  double scroll = 0.0;  // wheel clicks since the last frame
};

enum class Gesture { kNone, kOrbit, kPan, kDrag, kTool };

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

double g_scroll = 0.0;  // GLFW's wheel callback has no user pointer of ours (ImGui owns it)
void on_scroll(GLFWwindow*, double, double dy) {
  g_scroll += dy;
}

std::string default_screenshot_name() {
  static int n = 0;
  return fmt::format("lamina_view_{:03d}.png", ++n);
}

}  // namespace

struct Viewer::Impl {
  ViewerOptions options;
  std::unique_ptr<ViewerModel> vm;
  std::unique_ptr<interact::RealtimeLoop> loop;
  interact::LoopSnapshot snap;

  // Live parameters (the panels edit these, then hand them to the loop).
  sim::Material material;
  sim::SolverOptions solver;
  interact::RoutingOptions routing;
  double last_volume_kpa = 1.0;  // what the volume term comes back at when ticked again
  double rate_hz = 1000.0;
  bool paused = false;
  std::string param_error;

  // Display.
  Camera camera;
  Style style;
  bool show_rings = true;
  float arrow_mm_per_n = 60.0f;
  int inner_choice = 0, coloring_choice = 0;

  // Interaction.
  bool tool_mode = false;
  Gesture gesture = Gesture::kNone;
  Eigen::Vector2d press_pos = Eigen::Vector2d::Zero(), last_pos = Eigen::Vector2d::Zero();
  int32_t drag_node = -1;
  Eigen::Vector3d grab_point = Eigen::Vector3d::Zero();
  Eigen::Vector3d drag_force = Eigen::Vector3d::Zero();  // mN
  std::vector<interact::LiveForce> pinned, sent;
  interact::ToolTip tip;
  double tool_depth_mm = 0.0;
  int32_t watched = -1;

  // Plots.
  History h_displacement, h_volume, h_step_us, h_rate;

  // Rebuild in the background.
  int rebuild_layers = 2, rebuild_vertices = 1284;
  std::thread rebuild_thread;
  std::atomic<bool> rebuilding{false};
  std::mutex rebuild_mutex;
  std::string rebuild_stage, rebuild_error;
  double rebuild_fraction = 0.0;
  std::unique_ptr<ViewerModel> rebuilt;

  // Script and report.
  std::vector<ScriptEvent> script;
  size_t script_next = 0;
  bool script_drives_mouse = false;  // else the real mouse stays live (xdotool, a person)
  Input scripted;
  std::optional<ScriptEvent> glide;  // a mouse glide in progress
  Eigen::Vector2d glide_from = Eigen::Vector2d::Zero();
  bool quit = false;
  int64_t frames = 0;
  double max_displacement_mm = 0.0, frame_seconds = 0.0;
  int64_t drags = 0, rebuilds = 0;
  // What the report says about real time and about the last drag: where the organ dented
  // most while it was dragged, and how far it was from rest 3 s (wall time) after the release.
  double min_real_time_factor = 0.0;  // over the run after its first second; 0 = not yet
  int frame_interval_us = 16667;      // the frame pacing: 60 Hz, slower while the loop is behind
  bool behind_seen = false;
  double drag_peak_mm = 0.0;
  int32_t drag_peak_node = -1, last_drag_node = -1;
  double released_at_s = -1.0, settle_3s_mm = -1.0;
  Clock::time_point start_time = Clock::now();  // show()'s clock, which scripts also follow
  std::vector<std::string> screenshots;
  std::string status;
  std::string window_shot;  // taken after the panels are drawn, before the buffers swap
  char screenshot_path[512] = "";
  char export_path[512] = "lamina_skin.obj";

  GLFWwindow* window = nullptr;
  std::unique_ptr<Renderer> renderer;

  void start_loop() {
    routing.locality = std::min(routing.locality, vm->model.rings.locality);
    sim::Simulation s = sim::make_simulation(vm->model, material, solver);
    sim::fix_nodes(s, vm->fixed);
    sim::support_nodes(s, vm->support.nodes, vm->support.stiffness_n_per_m);
    interact::LoopOptions lo;
    lo.rate_hz = rate_hz;
    lo.threads = 1;  // the window draws on the other core (llvmpipe renders on the CPU)
    loop = std::make_unique<interact::RealtimeLoop>(std::move(s), routing, lo);
    pinned.clear();
    for (const auto& [node, force] : vm->pinned) pinned.push_back({node, force});
    sent = pinned;
    loop->set_forces(pinned);
    loop->set_paused(paused);
    snap = {};
    loop->latest(snap);
    loop->start();
    watched = vm->watched_node >= 0 ? vm->watched_node : (pinned.empty() ? 0 : pinned[0].node);
    rebuild_layers = vm->model.layer_count();
    rebuild_vertices = vm->model.layers.empty() ? 0 : vm->model.layers[0].node_count;
  }

  void push_parameters() {
    try {
      loop->set_parameters(material, solver, routing);
      loop->set_rate(rate_hz);
      param_error.clear();
    } catch (const Error& e) {
      param_error = e.what();
    }
  }

  void update_forces() {
    std::vector<interact::LiveForce> now = pinned;
    if (gesture == Gesture::kDrag && drag_force.norm() > 0.0)
      now.push_back({drag_node, drag_force});
    const bool same = now.size() == sent.size() &&
                      std::equal(now.begin(), now.end(), sent.begin(), [](auto& a, auto& b) {
                        return a.node == b.node && a.force_mn == b.force_mn;
                      });
    if (same) return;
    sent = now;
    loop->set_forces(now);
  }

  int width() const {
    int w = 0, h = 0;
    glfwGetWindowSize(window, &w, &h);
    return w;
  }
  int height() const {
    int w = 0, h = 0;
    glfwGetWindowSize(window, &w, &h);
    return h;
  }

  // ---- input -------------------------------------------------------------------------------

  Input poll_real_input() {
    Input in;
    glfwGetCursorPos(window, &in.pos.x(), &in.pos.y());
    in.buttons[0] = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
    in.buttons[1] = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS;
    in.buttons[2] = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_MIDDLE) == GLFW_PRESS;
    in.shift = glfwGetKey(window, GLFW_KEY_LEFT_SHIFT) == GLFW_PRESS ||
               glfwGetKey(window, GLFW_KEY_RIGHT_SHIFT) == GLFW_PRESS;
    in.scroll = g_scroll;
    g_scroll = 0.0;
    return in;
  }

  // Replays script events due by time t into `scripted`; returns keys pressed.
  std::vector<std::string> run_script(double t) {
    std::vector<std::string> keys;
    const Eigen::Vector2d size(width(), height());
    scripted.scroll = 0.0;
    if (glide) {
      const double f =
          glide->over_s > 0.0 ? std::clamp((t - glide->at_s) / glide->over_s, 0.0, 1.0) : 1.0;
      scripted.pos = glide_from + f * (glide->mouse->cwiseProduct(size) - glide_from);
      if (f >= 1.0) glide.reset();
    }
    while (script_next < script.size() && script[script_next].at_s <= t) {
      const ScriptEvent& e = script[script_next++];
      if (e.mouse) {
        if (e.over_s > 0.0) {
          glide = e;
          glide_from = scripted.pos;
        } else {
          glide.reset();
          scripted.pos = e.mouse->cwiseProduct(size);
        }
      }
      if (e.shift) scripted.shift = *e.shift;
      if (e.press >= 0) scripted.buttons[e.press] = true;
      if (e.release >= 0) scripted.buttons[e.release] = false;
      scripted.scroll += e.scroll;
      if (!e.mode.empty()) tool_mode = e.mode == "tool";
      if (!e.key.empty()) keys.push_back(e.key);
      if (!e.screenshot.empty()) save_screenshot(e.screenshot);
      if (!e.window_screenshot.empty()) window_shot = e.window_screenshot;
      if (e.rebuild_layers > 0) {
        rebuild_layers = e.rebuild_layers;
        rebuild_vertices = e.rebuild_skin_vertices;
        start_rebuild();
      }
      if (e.quit) quit = true;
    }
    return keys;
  }

  void handle_key(const std::string& key) {
    if (key == "r") {
      loop->reset();
    } else if (key == "space") {
      paused = !paused;
      loop->set_paused(paused);
    } else if (key == "c") {
      pinned.clear();
      update_forces();
    } else if (key == "t") {
      tool_mode = !tool_mode;
    }
  }

  void handle_mouse(const Input& in, const Input& prev, bool ui_wants_mouse) {
    const int w = width(), h = height();
    const Eigen::Vector2d delta = in.pos - last_pos;
    last_pos = in.pos;
    if (gesture == Gesture::kNone && !ui_wants_mouse) {
      if (in.buttons[0] && !prev.buttons[0]) {
        press_pos = in.pos;
        const Ray ray = pixel_ray(camera, w, h, in.pos.x(), in.pos.y());
        const interact::SkinHit hit =
            interact::pick_skin(vm->model, snap.x, ray.origin, ray.direction);
        if (tool_mode) {
          gesture = Gesture::kTool;
          tool_depth_mm =
              hit.node >= 0 ? hit.distance_mm - tip.radius_mm : (camera.target - ray.origin).norm();
        } else if (hit.node >= 0) {
          gesture = Gesture::kDrag;
          drag_node = hit.node;
          grab_point = snap.x.row(hit.node).transpose();
          drag_force.setZero();
          watched = hit.node;
          last_drag_node = hit.node;
          drag_peak_mm = 0.0;
          drag_peak_node = -1;
          released_at_s = -1.0;
          settle_3s_mm = -1.0;
          ++drags;
        } else {
          gesture = Gesture::kOrbit;
        }
      } else if ((in.buttons[1] && !prev.buttons[1]) || (in.buttons[2] && !prev.buttons[2])) {
        gesture = Gesture::kPan;
      }
      if (in.scroll != 0.0) zoom(camera, std::pow(0.9, in.scroll));
    }
    switch (gesture) {
      case Gesture::kOrbit:
        orbit(camera, -0.3 * delta.x(), 0.3 * delta.y());
        if (!in.buttons[0]) gesture = Gesture::kNone;
        break;
      case Gesture::kPan:
        pan(camera, h, delta.x(), delta.y());
        if (!in.buttons[1] && !in.buttons[2]) gesture = Gesture::kNone;
        break;
      case Gesture::kDrag: {
        // The paper's interaction: force = gain x drag, the drag measured in the plane facing
        // the eye at the grabbed point.
        const Eigen::Vector2d d = in.pos - press_pos;
        drag_force = 1000.0 * options.gain_n_per_mm *
                     drag_in_view_plane(camera, h, grab_point, d.x(), d.y());
        if (!in.buttons[0]) {
          if (in.shift && drag_force.norm() > 0.0) pinned.push_back({drag_node, drag_force});
          gesture = Gesture::kNone;
          drag_force.setZero();
          released_at_s = seconds_since(start_time);
        }
        update_forces();
        break;
      }
      case Gesture::kTool: {
        tool_depth_mm = std::max(1.0, tool_depth_mm + 2.0 * in.scroll);
        const Ray ray = pixel_ray(camera, w, h, in.pos.x(), in.pos.y());
        tip.center_mm = ray.origin + tool_depth_mm * ray.direction;
        tip.active = in.buttons[0];
        loop->set_tool_tip(tip);
        if (!in.buttons[0]) gesture = Gesture::kNone;
        break;
      }
      case Gesture::kNone:
        break;
    }
  }

  // ---- drawing ------------------------------------------------------------------------------

  Frame make_frame() const {
    Frame f;
    f.model = &vm->model;
    f.x = &snap.x;
    f.style = style;
    for (const interact::LiveForce& lf : sent) {
      add_force_arrow(f, lf.node, lf.force_mn, arrow_mm_per_n);
      if (show_rings) f.rings.push_back({lf.node, routing.locality});
    }
    for (int32_t node : snap.contact_nodes) add_contact_marker(f, node);
    if (tip.active) f.markers.push_back({tip.center_mm, tip.radius_mm, {0.7f, 0.75f, 0.8f, 1.0f}});
    return f;
  }

  void save_screenshot(std::string path) {
    if (path.empty()) path = default_screenshot_name();
    try {
      int fw = 0, fh = 0;
      glfwGetFramebufferSize(window, &fw, &fh);
      write_png(render_image(*renderer, make_frame(), camera, fw, fh), path);
      screenshots.push_back(path);
      status = "saved " + path;
    } catch (const Error& e) {
      status = e.what();
    }
  }

  void export_skin(const std::string& path) {
    try {
      SurfaceMesh mesh = model::layer_mesh(vm->model, 0);
      mesh.V = snap.x.topRows(vm->model.layers[0].node_count);
      io::write_mesh(mesh, path);
      status = "exported the skin to " + path;
    } catch (const Error& e) {
      status = e.what();
    }
  }

  // ---- panels -------------------------------------------------------------------------------

  void panels() {
    ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_FirstUseEver);
    ImGui::SetNextWindowSize(ImVec2(440, 0), ImGuiCond_FirstUseEver);
    ImGui::Begin("Lamina");
    const Model& m = vm->model;
    ImGui::TextWrapped("%s", vm->source.c_str());
    ImGui::Text("%d nodes, %zu springs, %d layers, %d skin vertices", m.node_count(),
                m.springs.size(), m.layer_count(), m.layers.empty() ? 0 : m.layers[0].node_count);
    ImGui::Text("t = %.2f s, step %lld%s", snap.time_s, static_cast<long long>(snap.steps),
                paused ? "  (paused)" : "");
    ImGui::Text("rate %.0f Hz (target %s), step %.0f us, jitter %.0f us", snap.achieved_rate_hz,
                rate_hz > 0 ? fmt::format("{:.0f}", rate_hz).c_str() : "max", snap.mean_step_us,
                snap.worst_jitter_us);
    // Real time or not, always in view: a slow machine shows a slow-motion organ, and says so.
    if (rate_hz <= 0.0)
      ImGui::TextColored(ImVec4(0.8f, 0.8f, 0.8f, 1), "as fast as possible: %.2fx real time",
                         snap.real_time_factor);
    else if (snap.keeping_up)
      ImGui::TextColored(ImVec4(0.4f, 0.9f, 0.4f, 1), "real time: %.3g ms steps, %.2fx",
                         1000.0 * snap.dt_s, snap.real_time_factor);
    else
      ImGui::TextColored(ImVec4(1.0f, 0.45f, 0.3f, 1),
                         "BEHIND real time: %.2fx (slow motion); lower the rate or the model "
                         "size to keep up",
                         snap.real_time_factor);
    ImGui::Text("max displacement %.2f mm, volume change %+.3f %%", snap.stats.max_displacement_mm,
                snap.stats.volume_change_pct);
    ImGui::Text("reaction (%.0f, %.0f, %.0f) mN", snap.reaction_mn.x(), snap.reaction_mn.y(),
                snap.reaction_mn.z());
    if (snap.recoveries > 0)
      ImGui::TextColored(ImVec4(1, 0.6f, 0.2f, 1), "%lld unstable steps rolled back",
                         static_cast<long long>(snap.recoveries));
    if (ImGui::Button("Reset (R)")) handle_key("r");
    ImGui::SameLine();
    if (ImGui::Button(paused ? "Resume (Space)" : "Pause (Space)")) handle_key("space");
    ImGui::SameLine();
    if (ImGui::Button("Release pinned (C)")) handle_key("c");

    bool changed = false;
    if (ImGui::CollapsingHeader("Interaction", ImGuiTreeNodeFlags_DefaultOpen)) {
      int mode = tool_mode ? 1 : 0;
      ImGui::RadioButton("drag (paper)", &mode, 0);
      ImGui::SameLine();
      ImGui::RadioButton("tool tip (T)", &mode, 1);
      tool_mode = mode == 1;
      ImGui::InputDouble("gain N/mm", &options.gain_n_per_mm, 0.01, 0.1, "%.3f");
      options.gain_n_per_mm = std::clamp(options.gain_n_per_mm, 0.0, 10.0);
      ImGui::Text("%zu pinned force(s); Shift+release pins a drag", pinned.size());
      float radius = static_cast<float>(tip.radius_mm),
            k = static_cast<float>(tip.stiffness_n_per_m);
      if (ImGui::SliderFloat("tip radius mm", &radius, 1.0f, 30.0f)) tip.radius_mm = radius;
      if (ImGui::SliderFloat("tip stiffness N/m", &k, 1.0f, 500.0f, "%.0f",
                             ImGuiSliderFlags_Logarithmic))
        tip.stiffness_n_per_m = k;
    }
    if (ImGui::CollapsingHeader("Material", ImGuiTreeNodeFlags_DefaultOpen)) {
      if (material.young_modulus_kpa > 0.0) {
        // The physical tissue in the tetrahedra: E and nu identify every spring and volume term
        // again when they change (a few milliseconds on the paper-size liver).
        changed |= ImGui::InputDouble("Young's modulus E kPa", &material.young_modulus_kpa, 0.5, 2,
                                      "%.3g");
        changed |= ImGui::InputDouble("Poisson's ratio nu", &material.poisson_ratio, 0.01, 0.05,
                                      "%.3f");
        int coupled = material.tet_elasticity == model::TetElasticity::kCoupled ? 0 : 1;
        if (ImGui::Combo("tetrahedra", &coupled, "coupled springs\0independent springs\0")) {
          material.tet_elasticity =
              coupled == 0 ? model::TetElasticity::kCoupled : model::TetElasticity::kSprings;
          changed = true;
        }
      } else {
        changed |= ImGui::InputDouble("stiffness K N/m", &material.stiffness_n_per_m, 0.5, 5, "%.3f");
      }
      changed |=
          ImGui::InputDouble("damping gamma kg/s", &material.damping_kg_per_s, 0.5, 5, "%.3f");
      changed |=
          ImGui::InputDouble("node mass kg (0 = lumped)", &material.node_mass_kg, 0.1, 1, "%.4g");
      changed |=
          ImGui::InputDouble("anchor N/m", &material.anchor_stiffness_n_per_m, 0.1, 1, "%.3f");
      changed |= ImGui::InputDouble("mass damping alpha 1/s", &material.mass_damping_per_s, 1, 10,
                                    "%.4g");
      // The volume term: 0 is the paper's model; a physical scene starts at lambda - mu.
      bool volume = material.volume_stiffness_kpa > 0.0;
      if (ImGui::Checkbox("volume term", &volume)) {
        material.volume_stiffness_kpa = volume ? std::max(last_volume_kpa, 1e-3) : 0.0;
        changed = true;
      }
      if (volume) {
        changed |= ImGui::InputDouble("volume stiffness kPa", &material.volume_stiffness_kpa, 0.5,
                                      5, "%.4g");
        last_volume_kpa = material.volume_stiffness_kpa;
      }
    }
    if (ImGui::CollapsingHeader("Solver", ImGuiTreeNodeFlags_DefaultOpen)) {
      // The combo's order is the enum's: semi-implicit, implicit (CG), projective.
      int integrator = static_cast<int>(solver.integrator);
      if (ImGui::Combo("integrator", &integrator,
                       "semi-implicit Euler\0implicit Euler (CG)\0projective (Liu 2013)\0")) {
        solver.integrator = static_cast<sim::Integrator>(integrator);
        changed = true;
      }
      int mode = solver.mode == sim::Mode::kLocal ? 1 : 0;
      if (ImGui::Combo("mode", &mode, "global\0local (paper)\0")) {
        solver.mode = mode ? sim::Mode::kLocal : sim::Mode::kGlobal;
        changed = true;
      }
      changed |= ImGui::InputDouble("dt s", &solver.dt_s, 0.001, 0.01, "%.4f");
      changed |= ImGui::InputDouble("rest speed mm/s", &solver.rest_speed_mm_per_s, 0.0, 0.0, "%.2g");
      changed |= ImGui::InputInt("CG iterations", &solver.cg_max_iterations);
      changed |= ImGui::InputInt("projective iterations", &solver.projective_iterations);
      changed |= ImGui::InputDouble("rate Hz (0 = max)", &rate_hz, 100, 1000, "%.0f");
      ImGui::Text("last step: max move %.2e mm %s", snap.stats.max_move_mm,
                  snap.stats.converged ? "(below threshold)" : "");
    }
    if (ImGui::CollapsingHeader("Force routing", ImGuiTreeNodeFlags_DefaultOpen)) {
      changed |=
          ImGui::SliderInt("locality N", &routing.locality, 1, std::max(1, m.rings.locality));
      changed |=
          ImGui::SliderInt("penetration P", &routing.penetration_depth, 1, 2 * m.layer_count() + 2);
      float ra = static_cast<float>(routing.ring_attenuation),
            ca = static_cast<float>(routing.crossing_attenuation);
      if (ImGui::SliderFloat("ring attenuation", &ra, 0.0f, 1.0f))
        routing.ring_attenuation = ra, changed = true;
      if (ImGui::SliderFloat("crossing attenuation", &ca, 0.0f, 1.0f))
        routing.crossing_attenuation = ca, changed = true;
      changed |=
          ImGui::InputDouble("contact threshold mm", &routing.contact_threshold_mm, 1, 5, "%.1f");
    }
    if (changed) push_parameters();
    if (!param_error.empty())
      ImGui::TextColored(ImVec4(1, 0.35f, 0.3f, 1), "%s", param_error.c_str());

    if (ImGui::CollapsingHeader("Display")) {
      if (ImGui::Combo("inner layers", &inner_choice, "hidden\0translucent\0wireframe\0")) {
        style.inner = static_cast<InnerLayers>(inner_choice);
        style.skin_alpha = style.inner == InnerLayers::kHidden ? 1.0f : 0.35f;
      }
      ImGui::SliderFloat("skin opacity", &style.skin_alpha, 0.05f, 1.0f);
      ImGui::Checkbox("skin wireframe", &style.skin_wireframe);
      ImGui::SameLine();
      ImGui::Checkbox("springs", &style.springs);
      if (ImGui::Combo("colour", &coloring_choice, "organ\0displacement\0"))
        style.coloring = static_cast<Coloring>(coloring_choice);
      ImGui::Checkbox("rings of contacts (fig. 2)", &show_rings);
      ImGui::SliderFloat("arrow mm per N", &arrow_mm_per_n, 5.0f, 300.0f, "%.0f",
                         ImGuiSliderFlags_Logarithmic);
      if (ImGui::Button("Fit view")) camera = fit_camera(m);
    }
    if (ImGui::CollapsingHeader("Model")) {
      ImGui::BeginDisabled(!options.rebuild || rebuilding);
      ImGui::InputInt("layers S", &rebuild_layers);
      ImGui::InputInt("skin vertices", &rebuild_vertices, 100, 1000);
      rebuild_layers = std::clamp(rebuild_layers, 1, 16);
      rebuild_vertices = std::clamp(rebuild_vertices, 50, 500000);
      if (ImGui::Button("Rebuild")) start_rebuild();
      ImGui::EndDisabled();
      if (!options.rebuild)
        ImGui::TextWrapped("(a saved model cannot be rebuilt here: view its segmentation instead)");
      if (rebuilding) {
        std::lock_guard lock(rebuild_mutex);
        ImGui::ProgressBar(static_cast<float>(rebuild_fraction), ImVec2(-1, 0),
                           rebuild_stage.c_str());
      }
      if (!rebuild_error.empty())
        ImGui::TextColored(ImVec4(1, 0.35f, 0.3f, 1), "%s", rebuild_error.c_str());
    }
    if (ImGui::CollapsingHeader("Save")) {
      ImGui::InputText("PNG", screenshot_path, sizeof screenshot_path);
      if (ImGui::Button("Screenshot (S)")) save_screenshot(screenshot_path);
      ImGui::InputText("mesh", export_path, sizeof export_path);
      if (ImGui::Button("Export deformed skin")) export_skin(export_path);
    }
    if (!status.empty()) ImGui::TextWrapped("%s", status.c_str());
    ImGui::End();

    ImGui::SetNextWindowPos(ImVec2(static_cast<float>(width()) - 430, 10), ImGuiCond_FirstUseEver);
    ImGui::SetNextWindowSize(ImVec2(420, 370), ImGuiCond_FirstUseEver);
    ImGui::Begin("Plots (last 600 frames)");
    plot("displacement of node " + std::to_string(watched) + ", mm", h_displacement);
    plot("skin volume change, %", h_volume);
    plot("step time, us", h_step_us);
    plot("simulation rate, Hz", h_rate);
    ImGui::End();
  }

  static void plot(const std::string& label, const History& h) {
    float lo = 0.0f, hi = 0.0f;
    for (int i = 0; i < h.count; ++i) {
      const float v = h.values[(h.next + History::kLength - h.count + i) % History::kLength];
      lo = i ? std::min(lo, v) : v, hi = i ? std::max(hi, v) : v;
    }
    if (hi - lo < 1e-6f) hi = lo + 1e-6f;
    const std::string overlay = fmt::format("{}: {:.4g}", label, h.last());
    ImGui::PlotLines(("##" + label).c_str(), h.values.data(), History::kLength, h.next,
                     overlay.c_str(), lo, hi,
                     ImVec2(std::max(ImGui::GetContentRegionAvail().x, 100.0f), 70));
  }

  void record_plots() {
    if (watched >= 0 && watched < snap.x.rows())
      h_displacement.push(
          static_cast<float>((snap.x.row(watched) - vm->model.X.row(watched)).norm()));
    h_volume.push(static_cast<float>(snap.stats.volume_change_pct));
    h_step_us.push(static_cast<float>(snap.mean_step_us));
    h_rate.push(static_cast<float>(snap.achieved_rate_hz));
  }

  // ---- rebuild ------------------------------------------------------------------------------

  void start_rebuild() {
    if (rebuilding || !options.rebuild) return;
    if (rebuild_thread.joinable()) rebuild_thread.join();
    rebuilding = true;
    rebuild_error.clear();
    rebuild_thread = std::thread([this, layers = rebuild_layers, verts = rebuild_vertices] {
      try {
        auto progress = [this](std::string_view stage, double fraction) {
          std::lock_guard lock(rebuild_mutex);
          rebuild_stage = std::string(stage);
          rebuild_fraction = fraction;
        };
        auto result = std::make_unique<ViewerModel>(options.rebuild(layers, verts, progress));
        std::lock_guard lock(rebuild_mutex);
        rebuilt = std::move(result);
      } catch (const std::exception& e) {
        std::lock_guard lock(rebuild_mutex);
        rebuild_error = e.what();
      }
      rebuilding = false;
    });
  }

  void adopt_rebuilt() {
    std::unique_ptr<ViewerModel> next;
    {
      std::lock_guard lock(rebuild_mutex);
      next = std::move(rebuilt);
    }
    if (!next) return;
    loop->stop();
    loop.reset();  // the loop points into the old model: stop it before replacing the model
    renderer->forget_model();
    vm = std::move(next);
    if (vm->material) material = *vm->material;
    gesture = Gesture::kNone;
    start_loop();
    ++rebuilds;
    status = fmt::format("rebuilt: {} nodes, {} layers", vm->model.node_count(),
                         vm->model.layer_count());
  }

  // The report's record of real time and of the last drag (see their fields).
  void watch_real_time_and_drag(double t) {
    if (t > 1.5 && snap.real_time_factor > 0.0 && !paused) {
      min_real_time_factor = min_real_time_factor > 0.0
                                 ? std::min(min_real_time_factor, snap.real_time_factor)
                                 : snap.real_time_factor;
      behind_seen = behind_seen || !snap.keeping_up;
    }
    if (gesture == Gesture::kDrag && snap.x.rows() == vm->model.node_count()) {
      Eigen::Index node = 0;
      const double peak = (snap.x - vm->model.X).rowwise().norm().maxCoeff(&node);
      if (peak > drag_peak_mm) drag_peak_mm = peak, drag_peak_node = static_cast<int32_t>(node);
    }
    if (released_at_s >= 0.0 && settle_3s_mm < 0.0 && t >= released_at_s + 3.0)
      settle_3s_mm = snap.stats.max_displacement_mm;
  }

  void write_report() {
    if (options.report.empty()) return;
    nlohmann::json j;
    j["frames"] = frames;
    j["mean_frame_ms"] = frames ? 1000.0 * frame_seconds / static_cast<double>(frames) : 0.0;
    j["sim_steps"] = snap.steps;
    j["sim_time_s"] = snap.time_s;
    j["achieved_rate_hz"] = snap.achieved_rate_hz;
    j["dt_s"] = snap.dt_s;
    j["real_time_factor"] = snap.real_time_factor;
    j["min_real_time_factor"] = min_real_time_factor;
    j["fell_behind"] = behind_seen;
    j["drag_node"] = last_drag_node;
    j["drag_peak_displacement_mm"] = drag_peak_mm;
    j["drag_peak_node"] = drag_peak_node;
    if (drag_peak_node >= 0 && last_drag_node >= 0)
      j["drag_peak_distance_from_drag_mm"] =
          (vm->model.X.row(drag_peak_node) - vm->model.X.row(last_drag_node)).norm();
    j["max_displacement_3s_after_release_mm"] = settle_3s_mm;
    j["max_displacement_mm"] = max_displacement_mm;
    j["final_max_displacement_mm"] = snap.stats.max_displacement_mm;
    j["final_volume_change_pct"] = snap.stats.volume_change_pct;
    j["recoveries"] = snap.recoveries;
    j["drags"] = drags;
    j["pinned_forces"] = pinned.size();
    j["nodes"] = vm->model.node_count();
    j["layers"] = vm->model.layer_count();
    j["rebuilds"] = rebuilds;
    j["screenshots"] = screenshots;
    const std::string text = j.dump(2);
    write_file_atomically(options.report, [&](std::ostream& out) { out << text << "\n"; });
  }
};

void check_display() {
  const char* display = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  if ((!display || !*display) && (!wayland || !*wayland))
    throw Error(ErrorKind::kUnavailable,
                "no display (DISPLAY is not set): use `lamina render MODEL -o picture.png` for "
                "pictures without a window, or run the viewer under xvfb-run");
}

void check_viewer_script(const std::string& path) {
  load_viewer_script(path);
}

Viewer::Viewer(ViewerOptions options) : impl_(std::make_unique<Impl>()) {
  Impl& v = *impl_;
  v.material = options.material;
  if (v.material.volume_stiffness_kpa > 0.0) v.last_volume_kpa = v.material.volume_stiffness_kpa;
  v.solver = options.solver;
  v.routing = options.routing;
  v.rate_hz = options.rate_hz;
  v.options = std::move(options);
}

Viewer::~Viewer() {
  Impl& v = *impl_;
  if (v.rebuild_thread.joinable()) v.rebuild_thread.join();
}

void Viewer::set_model(ViewerModel model) {
  impl_->vm = std::make_unique<ViewerModel>(std::move(model));
}

int Viewer::show() {
  Impl& v = *impl_;
  if (!v.vm) throw Error(ErrorKind::kInternal, "Viewer::show() before set_model()");
  if (!v.options.script.empty()) v.script = load_viewer_script(v.options.script);
  for (const ScriptEvent& e : v.script)
    v.script_drives_mouse |=
        e.mouse || e.press >= 0 || e.release >= 0 || e.shift || e.scroll != 0.0;
  check_display();
  const char* display = std::getenv("DISPLAY");
  glfwSetErrorCallback(
      [](int code, const char* text) { log::logger().debug("GLFW {}: {}", code, text); });
  if (!glfwInit())
    throw Error(ErrorKind::kUnavailable,
                std::string("cannot open the display '") + (display ? display : "") +
                    "': use `lamina render MODEL -o picture.png` for pictures without a window");
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  const std::string title = v.options.title + " - " + v.vm->source;
  // Multisampling is free on a GPU but quadruples the fragment work of Mesa's CPU renderer
  // (measured under Xvfb: 70 ms against 25 ms a 1400x900 frame), so it is dropped there.
  for (int samples : {4, 0}) {
    glfwWindowHint(GLFW_SAMPLES, samples);
    v.window = glfwCreateWindow(v.options.width, v.options.height, title.c_str(), nullptr, nullptr);
    if (!v.window) continue;
    glfwMakeContextCurrent(v.window);
    const char* gl_renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
    const bool software =
        gl_renderer && (std::string(gl_renderer).find("llvmpipe") != std::string::npos ||
                        std::string(gl_renderer).find("softpipe") != std::string::npos);
    if (samples == 0 || !software) break;
    glfwDestroyWindow(v.window);
    v.window = nullptr;
  }
  if (!v.window) {
    glfwTerminate();
    throw Error(
        ErrorKind::kUnavailable,
        "cannot open an OpenGL 3.3 core window on this display: use `lamina render` instead");
  }
  glfwSwapInterval(1);
  glfwSetScrollCallback(v.window, on_scroll);  // before ImGui, which chains to it

  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // leave no imgui.ini behind in the user's folder
  ImGui::StyleColorsDark();
  ImGui_ImplGlfw_InitForOpenGL(v.window, true);
  ImGui_ImplOpenGL3_Init("#version 330 core");

  // However show() ends, the simulation thread, ImGui and the window are torn down in order.
  struct Teardown {
    Impl& v;
    ~Teardown() {
      if (v.loop) v.loop->stop();
      ImGui_ImplOpenGL3_Shutdown();
      ImGui_ImplGlfw_Shutdown();
      ImGui::DestroyContext();
      v.renderer.reset();
      glfwDestroyWindow(v.window);
      v.window = nullptr;
      glfwTerminate();
    }
  } teardown{v};
  v.renderer = std::make_unique<Renderer>();
  v.camera = fit_camera(v.vm->model);
  v.start_loop();
  const auto t0 = Clock::now();
  v.start_time = t0;
  Input prev;
  bool s_was_down = false;
  while (!glfwWindowShouldClose(v.window) && !v.quit) {
    const auto frame_start = Clock::now();
    glfwPollEvents();
    const double t = seconds_since(t0);
    Input in = v.poll_real_input();
    std::vector<std::string> keys;
    if (!v.script.empty()) {
      keys = v.run_script(t);
      if (v.script_drives_mouse) in = v.scripted;
    }
    v.loop->latest(v.snap);
    v.max_displacement_mm = std::max(v.max_displacement_mm, v.snap.stats.max_displacement_mm);
    v.watch_real_time_and_drag(t);
    v.record_plots();
    v.adopt_rebuilt();

    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    const ImGuiIO& io = ImGui::GetIO();
    if (!io.WantCaptureKeyboard) {
      for (auto [glfw_key, name] : {std::pair{GLFW_KEY_R, "r"},
                                    {GLFW_KEY_SPACE, "space"},
                                    {GLFW_KEY_C, "c"},
                                    {GLFW_KEY_T, "t"}})
        if (ImGui::IsKeyPressed(glfw_key, false)) keys.push_back(name);  // 1.86: native key codes
      const bool s_down = glfwGetKey(v.window, GLFW_KEY_S) == GLFW_PRESS;
      if (s_down && !s_was_down) v.save_screenshot(v.screenshot_path);
      s_was_down = s_down;
    }
    for (const std::string& k : keys) v.handle_key(k);
    v.handle_mouse(in, prev, io.WantCaptureMouse && !v.script_drives_mouse);
    prev = in;
    v.panels();
    ImGui::Render();

    int fw = 0, fh = 0;
    glfwGetFramebufferSize(v.window, &fw, &fh);
    if (fw > 0 && fh > 0) v.renderer->draw(v.make_frame(), v.camera, fw, fh);
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    if (!v.window_shot.empty() && fw > 0 && fh > 0) {
      glReadBuffer(GL_BACK);
      const Image img = read_pixels(fw, fh);
      try {
        write_png(img, v.window_shot);
        v.screenshots.push_back(v.window_shot);
      } catch (const Error& e) {
        v.status = e.what();
      }
      v.window_shot.clear();
    }
    glfwSwapBuffers(v.window);
    ++v.frames;
    v.frame_seconds += seconds_since(frame_start);
    // At most 60 frames a second even where the display has no vertical sync (Xvfb): the
    // simulation thread needs the other core more than the screen needs more frames. When the
    // simulation falls behind real time anyway (software GL drawing on the cores the physics
    // needs), the screen gives way: down to 15 frames a second until the loop keeps up again.
    v.frame_interval_us = v.snap.keeping_up ? std::max(16667, v.frame_interval_us * 9 / 10)
                                            : std::min(66667, v.frame_interval_us * 5 / 4);
    std::this_thread::sleep_until(frame_start + std::chrono::microseconds(v.frame_interval_us));
  }
  v.loop->stop();
  v.loop->latest(v.snap);
  v.watch_real_time_and_drag(seconds_since(t0));  // the last window counts in the report too
  v.write_report();
  // Said in the window while it happened; said again here, where a log keeps it.
  if (v.behind_seen)
    fmt::print(stderr,
               "lamina view: the simulation fell behind real time (down to {:.2f}x); lower the "
               "rate or the model size, or close other programs\n",
               v.min_real_time_factor);
  return 0;
}

}  // namespace lamina::render
