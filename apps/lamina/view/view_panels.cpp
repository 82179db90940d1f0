// The panels (Dear ImGui, drawn by the engine inside its frame): the model's state and whether
// it keeps real time, the interaction, material, solver and routing parameters (live), display
// choices, the rebuild, saving; and a window of plots over the last 600 frames.
#include <fmt/format.h>
#include <imgui.h>

#include <algorithm>

#include "lamina/model/embed_surface.h"
#include "lamina/render/camera.h"
#include "lamina/render/legend.h"
#include "parameter_widgets.h"
#include "view_session_state.h"

namespace lamina::cli {
namespace {

// The highest of the usual rates (haptic 1 kHz down to 15 Hz) whose step budget is at least
// twice the step time measured now; 0 if none.
double real_time_rate(double mean_step_us) {
  for (double hz : {1000.0, 500.0, 250.0, 120.0, 60.0, 30.0, 15.0})
    if (1e6 / hz >= 2.0 * mean_step_us) return hz;
  return 0.0;
}

void plot(const std::string& label, const History& h) {
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

// The left panel's place and width, pixels (where the viewer first puts it), and the plots
// panel's width at the window's right edge.
constexpr float kPanelMargin = 10.0f, kPanelWidth = 440.0f, kPlotsWidth = 420.0f;

}  // namespace

// The organ (its nodes: the anatomy's trunks beyond it are not framed) in the columns the two
// panels leave free: with the plots panel ignored, a real liver sat half behind it (issue 61).
void ViewSession::State::frame_organ(const Model& m) const {
  const Eigen::Vector2i size = render::window_size();
  render::camera() = render::frame_beside_panels(
      m, size.x(), size.y(), static_cast<int>(2.0f * kPanelMargin + kPanelWidth),
      static_cast<int>(2.0f * kPanelMargin + kPlotsWidth));
}

// The model's embedded surfaces: the display skin in place of the simulation's, and each
// structure inside the organ shown or not, in its colour.
void ViewSession::State::embedded_panel(const Model& m) {
  const int32_t skin = model::display_skin_index(m);
  if (skin >= 0) {
    const EmbeddedSurface& e = m.embedded[skin];
    ImGui::Checkbox("display skin", &style.display_skin);
    ImGui::SameLine();
    ImGui::TextDisabled("%lld triangles (simulation's: %lld)", static_cast<long long>(e.F.rows()),
                        static_cast<long long>(m.layers[0].F.rows()));
  }
  style.embedded.resize(m.embedded.size());
  for (size_t i = 0; i < m.embedded.size(); ++i) {
    if (static_cast<int32_t>(i) == skin) continue;
    const EmbeddedSurface& e = m.embedded[i];
    ImGui::PushID(static_cast<int>(i));
    ImGui::ColorEdit3("##colour", style.embedded[i].color.data(), ImGuiColorEditFlags_NoInputs);
    ImGui::SameLine();
    ImGui::Checkbox(e.name.c_str(), &style.embedded[i].visible);
    ImGui::SameLine();
    ImGui::TextDisabled("%lld vertices, %lld triangles", static_cast<long long>(e.V.rows()),
                        static_cast<long long>(e.F.rows()));
    ImGui::PopID();
  }
}

void ViewSession::State::panels() {
  ImGui::SetNextWindowPos(ImVec2(kPanelMargin, kPanelMargin), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(kPanelWidth, 0), ImGuiCond_FirstUseEver);
  ImGui::Begin("Lamina");
  const Model& m = vm->model;
  state_lines(m);
  if (ImGui::Button("Reset (R)")) handle_key("r");
  ImGui::SameLine();
  if (ImGui::Button(paused ? "Resume (Space)" : "Pause (Space)")) handle_key("space");
  ImGui::SameLine();
  if (ImGui::Button("Release pinned (C)")) handle_key("c");

  interaction_panel();
  plan_panel();
  bool changed = false;
  if (ImGui::CollapsingHeader("Material", ImGuiTreeNodeFlags_DefaultOpen))
    changed |= material_widgets(material, last_volume_kpa);
  if (ImGui::CollapsingHeader("Solver", ImGuiTreeNodeFlags_DefaultOpen)) {
    // In real time each step is 1/rate (OrganLoop): show that, not the scene's dt, which
    // only the "as fast as possible" rate 0 steps.
    changed |= solver_widgets(solver, rate_hz > 0.0 ? 1.0 / rate_hz : 0.0, "dt s (1/rate)");
    if (ImGui::InputDouble("rate Hz (0 = max)", &rate_hz, 100, 1000, "%.0f"))
      changed = true, auto_rate = false;  // a rate given: it is kept
    ImGui::Text("last step: max move %.2e mm %s", snap.stats.max_move_mm,
                snap.stats.converged ? "(below threshold)" : "");
    if (solver.integrator == sim::Integrator::kImplicitEuler)
      ImGui::Text("CG: %d iterations, %s", snap.stats.cg_iterations,
                  snap.multigrid ? "multigrid" : "Jacobi");
  }
  if (ImGui::CollapsingHeader("Force routing", ImGuiTreeNodeFlags_DefaultOpen))
    changed |= routing_widgets(m);
  if (changed) push_parameters();
  if (!param_error.empty())
    ImGui::TextColored(ImVec4(1, 0.35f, 0.3f, 1), "%s", param_error.c_str());

  display_panel(m);
  model_panel();
  if (ImGui::CollapsingHeader("Save")) {
    ImGui::InputText("PNG", screenshot_path, sizeof screenshot_path);
    if (ImGui::Button("Screenshot (S)")) view_shot = true;
    ImGui::InputText("mesh", export_path, sizeof export_path);
    if (ImGui::Button("Export deformed skin")) export_skin(export_path);
  }
  if (!status.empty()) ImGui::TextWrapped("%s", status.c_str());
  ImGui::End();

  plots_window();

  if (show_legend) {
    render::Frame shown;
    shown.model = &m;
    shown.style = style;
    render::legend_window(render::legend_entries(shown), /*bottom=*/true);
  }
}

// Where the model is and whether the loop keeps real time, always in view; unstable and
// recovered steps said in colour.
void ViewSession::State::state_lines(const Model& m) {
  ImGui::TextWrapped("%s", vm->source.c_str());
  ImGui::Text("%d nodes, %zu springs, %d layers, %d skin vertices", m.node_count(),
              m.springs.size(), m.layer_count(), m.layers.empty() ? 0 : m.layers[0].node_count);
  ImGui::Text("t = %.2f s, step %lld%s", snap.time_s, static_cast<long long>(snap.steps),
              paused ? "  (paused)" : "");
  ImGui::Text("rate %.0f Hz (target %s%s), step %.0f us, jitter %.0f us", snap.achieved_rate_hz,
              rate_hz > 0 ? fmt::format("{:.0f}", rate_hz).c_str() : "max",
              auto_rate ? ", what this machine keeps" : "", snap.mean_step_us,
              snap.worst_jitter_us);
  // Real time or not, always in view: a slow machine shows a slow-motion organ, and says so.
  if (rate_hz <= 0.0)
    ImGui::TextColored(ImVec4(0.8f, 0.8f, 0.8f, 1), "as fast as possible: %.2fx real time",
                       snap.real_time_factor);
  else if (snap.keeping_up)
    ImGui::TextColored(ImVec4(0.4f, 0.9f, 0.4f, 1), "real time: %.3g ms steps, %.2fx",
                       1000.0 * snap.dt_s, snap.real_time_factor);
  else {
    const double fits = real_time_rate(snap.mean_step_us);
    ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1.0f, 0.45f, 0.3f, 1));
    ImGui::TextWrapped("BEHIND real time: %.2fx (slow motion); %s", snap.real_time_factor,
                       fits > 0.0 ? fmt::format("{:.0f} Hz keeps up (Model panel), or fewer "
                                                "skin vertices",
                                                fits)
                                        .c_str()
                                  : "fewer skin vertices keep up");
    ImGui::PopStyleColor();
  }
  ImGui::Text("max displacement %.2f mm, volume change %+.3f %%", snap.stats.max_displacement_mm,
              snap.stats.volume_change_pct);
  ImGui::Text("reaction (%.0f, %.0f, %.0f) mN", snap.reaction_mn.x(), snap.reaction_mn.y(),
              snap.reaction_mn.z());
  if (snap.stats.unstable != sim::Instability::kNone) {
    ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1.0f, 0.25f, 0.2f, 1));
    ImGui::TextWrapped(
        "UNSTABLE at t = %.2f s, stopped: %s. Press R to reset; lower the gain, dt or the "
        "stiffness",
        snap.time_s, sim::describe(snap.stats.unstable));
    ImGui::PopStyleColor();
  }
  if (snap.recoveries > 0)
    ImGui::TextColored(ImVec4(1, 0.6f, 0.2f, 1), "%lld steps redone after leaving bounds",
                       static_cast<long long>(snap.recoveries));
}

// The tool, grasper or scalpel a drag is, and each one's settings.
void ViewSession::State::interaction_panel() {
  if (!ImGui::CollapsingHeader("Interaction", ImGuiTreeNodeFlags_DefaultOpen)) return;
  int mode = scalpel_mode ? 3 : grasp_mode ? 2 : tool_mode ? 1 : 0;
  ImGui::RadioButton("drag (paper)", &mode, 0);
  ImGui::SameLine();
  ImGui::RadioButton("tool tip (T)", &mode, 1);
  ImGui::SameLine();
  ImGui::RadioButton("grasper (G)", &mode, 2);
  ImGui::SameLine();
  ImGui::RadioButton("scalpel (K)", &mode, 3);
  tool_mode = mode == 1;
  grasp_mode = mode == 2;
  scalpel_mode = mode == 3;
  if (scalpel_mode) {
    float depth = static_cast<float>(scalpel_depth_mm);
    if (ImGui::SliderFloat("blade depth mm", &depth, 2.0f, 120.0f, "%.0f"))
      scalpel_depth_mm = depth;
    ImGui::TextWrapped(
        "Drag across the organ: the release cuts along the drag, %.0f mm deep "
        "along the view. %lld cut(s).%s%s",
        scalpel_depth_mm, static_cast<long long>(cuts),
        cut_message.empty() ? "" : " Last: ", cut_message.c_str());
    if (ImGui::Button("Undo cut (U)")) handle_key("u");
  }
  if (grasp_mode) {
    float jr = static_cast<float>(jaws.radius_mm);
    if (ImGui::SliderFloat("jaws radius mm", &jr, 1.0f, 20.0f)) jaws.radius_mm = jr;
    ImGui::Text("%zu skin node(s) held%s", snap.grasped_nodes.size(),
                grasp_held ? " (Shift+release kept it; C lets go)" : "");
  }
  ImGui::InputDouble("gain N/mm", &options.gain_n_per_mm, 0.01, 0.1, "%.3f");
  options.gain_n_per_mm = std::clamp(options.gain_n_per_mm, 0.0, 10.0);
  ImGui::Text("%zu pinned force(s); Shift+release pins a drag", pinned.size());
  float radius = static_cast<float>(tip.radius_mm), k = static_cast<float>(tip.stiffness_n_per_m);
  if (ImGui::SliderFloat("tip radius mm", &radius, 1.0f, 30.0f)) tip.radius_mm = radius;
  if (ImGui::SliderFloat("tip stiffness N/m", &k, 1.0f, 500.0f, "%.0f",
                         ImGuiSliderFlags_Logarithmic))
    tip.stiffness_n_per_m = k;
}

// The paper's rings and copies, or none; and what a tool touches. True when a parameter changed.
bool ViewSession::State::routing_widgets(const Model& m) {
  bool changed = false;
  // none: a push spread over the skin it touches, the tool feels minus its load; paper: the
  // reference paper's rings and copies through the layers.
  int route = routing.routing == interact::Routing::kPaper ? 1 : 0;
  if (ImGui::Combo("routing", &route, "none (force conserved)\0paper (rings, copies)\0")) {
    routing.routing = route == 1 ? interact::Routing::kPaper : interact::Routing::kNone;
    changed = true;
  }
  ImGui::BeginDisabled(routing.routing != interact::Routing::kPaper);
  changed |= ImGui::SliderInt("locality N", &routing.locality, 1, std::max(1, m.rings.locality));
  changed |=
      ImGui::SliderInt("penetration P", &routing.penetration_depth, 1, 2 * m.layer_count() + 2);
  float ra = static_cast<float>(routing.ring_attenuation),
        ca = static_cast<float>(routing.crossing_attenuation);
  if (ImGui::SliderFloat("ring attenuation", &ra, 0.0f, 1.0f))
    routing.ring_attenuation = ra, changed = true;
  if (ImGui::SliderFloat("crossing attenuation", &ca, 0.0f, 1.0f))
    routing.crossing_attenuation = ca, changed = true;
  // 0: the rings counted in mesh edges (the paper's: a finer mesh, a smaller area); a length:
  // rings by distance, the same area at every mesh size.
  float rs = static_cast<float>(routing.ring_spacing_mm);
  if (ImGui::SliderFloat("ring spacing mm", &rs, 0.0f, 30.0f, "%.2f"))
    routing.ring_spacing_mm = rs, changed = true;
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "0: the paper's rings, counted in mesh edges; a length: rings by distance "
        "along the skin, the same area at every mesh size");
  if (ImGui::SmallButton("ring spacing of the paper-size skin"))
    routing.ring_spacing_mm = interact::paper_ring_spacing_mm(m), changed = true;
  ImGui::EndDisabled();
  changed |=
      ImGui::InputDouble("contact threshold mm", &routing.contact_threshold_mm, 1, 5, "%.1f");
  // Without routing, tools touch the display skin (what is drawn) when the model has one.
  ImGui::BeginDisabled(routing.routing == interact::Routing::kPaper ||
                       model::display_skin_index(m) < 0);
  int touch = routing.touch == interact::Touch::kSkin ? 1 : 0;
  if (ImGui::Combo("touch", &touch, "display skin\0simulation skin\0")) {
    routing.touch = touch == 1 ? interact::Touch::kSkin : interact::Touch::kDisplaySkin;
    changed = true;
  }
  ImGui::EndDisabled();
  return changed;
}

// Inner layers, opacity, the embedded surfaces, colours and what else is drawn.
void ViewSession::State::display_panel(const Model& m) {
  if (!ImGui::CollapsingHeader("Display")) return;
  if (ImGui::Combo("inner layers", &inner_choice, "hidden\0translucent\0wireframe\0")) {
    style.inner = static_cast<render::InnerLayers>(inner_choice);
    style.skin_alpha = style.inner == render::InnerLayers::kHidden ? 1.0f : 0.35f;
  }
  ImGui::SliderFloat("skin opacity", &style.skin_alpha, 0.05f, 1.0f);
  embedded_panel(m);
  ImGui::Checkbox("legend", &show_legend);
  ImGui::Checkbox("skin wireframe", &style.skin_wireframe);
  ImGui::SameLine();
  ImGui::Checkbox("springs", &style.springs);
  if (ImGui::Combo("colour", &coloring_choice, "organ\0displacement\0"))
    style.coloring = static_cast<render::Coloring>(coloring_choice);
  ImGui::Checkbox("rings of contacts (fig. 2)", &show_rings);
  ImGui::SliderFloat("arrow mm per N", &arrow_mm_per_n, 5.0f, 300.0f, "%.0f",
                     ImGuiSliderFlags_Logarithmic);
  if (ImGui::Button("Fit view")) frame_organ(m);
}

// The rebuild (layers, skin vertices) and the rate that keeps this model in real time.
void ViewSession::State::model_panel() {
  if (!ImGui::CollapsingHeader("Model")) return;
  ImGui::BeginDisabled(!options.rebuild || rebuilding);
  ImGui::InputInt("layers S", &rebuild_layers);
  ImGui::InputInt("skin vertices", &rebuild_vertices, 100, 1000);
  rebuild_layers = std::clamp(rebuild_layers, 1, 16);
  rebuild_vertices = std::clamp(rebuild_vertices, 50, 500000);
  if (ImGui::Button("Rebuild")) start_rebuild();
  ImGui::EndDisabled();
  // Which rate keeps this model in real time: from the step time the loop measures now. A
  // lower rate means a longer step, which costs an implicit solve more iterations: the hint
  // keeps half its budget spare, and the loop says again whether it keeps up.
  if (snap.mean_step_us > 0.0) {
    const double max_hz = 1e6 / snap.mean_step_us;
    ImGui::TextWrapped("a step takes %.2f ms here: real time up to about %.0f steps/s",
                       snap.mean_step_us / 1000.0, max_hz);
    const double fits = real_time_rate(snap.mean_step_us);
    if (fits > 0.0 && fits != rate_hz) {
      if (ImGui::Button(
              fmt::format("Use {:.0f} Hz ({:.1f} ms steps)", fits, 1000.0 / fits).c_str())) {
        rate_hz = fits;
        auto_rate = false;
        push_parameters();
      }
    } else if (fits <= 0.0) {
      ImGui::TextColored(ImVec4(1.0f, 0.45f, 0.3f, 1),
                         "too slow for real time even at 15 Hz: fewer skin vertices");
    }
  }
  if (!options.rebuild)
    ImGui::TextWrapped("(a saved model cannot be rebuilt here: view its segmentation instead)");
  if (rebuilding) {
    std::lock_guard lock(rebuild_mutex);
    ImGui::ProgressBar(static_cast<float>(rebuild_fraction), ImVec2(-1, 0), rebuild_stage.c_str());
  }
  if (!rebuild_error.empty())
    ImGui::TextColored(ImVec4(1, 0.35f, 0.3f, 1), "%s", rebuild_error.c_str());
}

// The window of plots at the right edge, over the last 600 frames.
void ViewSession::State::plots_window() {
  ImGui::SetNextWindowPos(
      ImVec2(static_cast<float>(render::window_size().x()) - kPanelMargin - kPlotsWidth,
             kPanelMargin),
      ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(kPlotsWidth, 370), ImGuiCond_FirstUseEver);
  ImGui::Begin("Plots (last 600 frames)");
  plot("displacement of node " + std::to_string(watched) + ", mm", h_displacement);
  plot("skin volume change, %", h_volume);
  plot("step time, us", h_step_us);
  plot("simulation rate, Hz", h_rate);
  ImGui::End();
}

void ViewSession::State::record_plots() {
  if (watched >= 0 && watched < snap.x.rows())
    h_displacement.push(
        static_cast<float>((snap.x.row(watched) - vm->model.X.row(watched)).norm()));
  h_volume.push(static_cast<float>(snap.stats.volume_change_pct));
  h_step_us.push(static_cast<float>(snap.mean_step_us));
  h_rate.push(static_cast<float>(snap.achieved_rate_hz));
}

}  // namespace lamina::cli
