// The world view's panel (its clock, whether it keeps real time, each body's measures, the
// attachments, the stages' share of a step), what it hands the engine each frame (every body's
// positions; the ties as beads, the forces as arrows) and its report.
#include <fmt/format.h>
#include <imgui.h>

#include <algorithm>

#include "lamina/core/error.h"
#include "lamina/interact/rate_choice.h"
#include "parameter_widgets.h"
#include "world_view_state.h"

namespace lamina::cli {

void WorldViewSession::State::panel() {
  ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(480, 0), ImGuiCond_FirstUseEver);
  ImGui::Begin("Lamina world");
  ImGui::TextWrapped("%s", scene.source.c_str());
  ImGui::Text("t = %.2f s, step %lld%s", snap.time_s, static_cast<long long>(snap.steps),
              paused ? "  (paused)" : "");
  ImGui::Text("rate %.0f Hz (target %s%s), step %.0f us", snap.rate.achieved_rate_hz,
              rate_hz > 0 ? fmt::format("{:.0f}", rate_hz).c_str() : "max",
              auto_rate ? ", what this machine keeps" : "", snap.rate.mean_step_us);
  if (rate_hz <= 0.0)
    ImGui::TextColored(ImVec4(0.8f, 0.8f, 0.8f, 1), "as fast as possible: %.2fx real time",
                       snap.rate.real_time_factor);
  else if (snap.rate.keeping_up)
    ImGui::TextColored(ImVec4(0.4f, 0.9f, 0.4f, 1), "real time: %.3g ms steps, %.2fx",
                       1000.0 * snap.dt_s, snap.rate.real_time_factor);
  else
    ImGui::TextColored(ImVec4(1.0f, 0.45f, 0.3f, 1),
                       "BEHIND real time: %.2fx (slow motion); a lower rate keeps up",
                       snap.rate.real_time_factor);
  if (snap.step_us > 0.0)
    ImGui::Text("step: tools %.0f%%, contact %.0f%%, solve %.0f%%",
                100.0 * snap.profile.tools_us / snap.step_us,
                100.0 * snap.profile.contact_us / snap.step_us,
                100.0 * snap.profile.solve_us / snap.step_us);
  if (snap.unstable != sim::Instability::kNone) {
    ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1.0f, 0.25f, 0.2f, 1));
    ImGui::TextWrapped("UNSTABLE: body '%s', %s; stopped. Press R to reset; lower the gain",
                       snap.unstable_body.c_str(), sim::describe(snap.unstable));
    ImGui::PopStyleColor();
  }
  if (ImGui::BeginTable("bodies", 4)) {
    ImGui::TableSetupColumn("body");
    ImGui::TableSetupColumn("nodes");
    ImGui::TableSetupColumn("moved, mm");
    ImGui::TableSetupColumn("in contact (deepest)");
    ImGui::TableHeadersRow();
    for (const world::BodyView& b : snap.bodies) {
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(b.name.c_str());
      ImGui::TableNextColumn();
      ImGui::Text("%d", b.model->node_count());
      ImGui::TableNextColumn();
      ImGui::Text("%.2f", b.stats.sim.max_displacement_mm);
      ImGui::TableNextColumn();
      ImGui::Text("%d (%.2f mm)", b.stats.contacts + b.stats.self_contacts,
                  b.stats.max_penetration_mm);
    }
    ImGui::EndTable();
  }
  for (const world::BodyView& b : snap.bodies)  // as the one-organ panel says it
    if (b.recoveries > 0)
      ImGui::TextColored(ImVec4(1, 0.6f, 0.2f, 1), "%s: %lld steps redone after leaving bounds",
                         b.name.c_str(), static_cast<long long>(b.recoveries));
  if (snap.tie_count.total > 0)
    ImGui::Text("attachments: %lld ties, %lld divided, %lld torn",
                static_cast<long long>(snap.tie_count.total),
                static_cast<long long>(snap.tie_count.divided),
                static_cast<long long>(snap.tie_count.torn));
  if (ImGui::Button("Reset (R)")) handle_key("r");
  ImGui::SameLine();
  if (ImGui::Button(paused ? "Resume (Space)" : "Pause (Space)")) handle_key("space");
  ImGui::SameLine();
  if (ImGui::Button("Release forces (C)")) handle_key("c");
  // One mode at a time: the one ticked clears the others.
  if (ImGui::Checkbox("dissection (X): drag across the tissue between two organs", &dissect_mode) &&
      dissect_mode)
    scalpel_mode = grasp_mode = false;
  if (ImGui::Checkbox("scalpel (K): drag to cut the organs' tissue", &scalpel_mode) && scalpel_mode)
    dissect_mode = grasp_mode = false;
  if (ImGui::Checkbox("grasper (G): press on an organ and drag to retract it", &grasp_mode) &&
      grasp_mode)
    dissect_mode = scalpel_mode = false;
  if (!snap.grasped_body.empty())
    ImGui::Text("grasper: holds %d skin nodes of %s, pulls %.0f mN%s", snap.grasped_nodes,
                snap.grasped_body.c_str(), snap.hands_reaction_mn.norm(),
                grasp_held ? " (Shift-released: C opens it)" : "");
  if (scalpel_mode) {
    float depth = static_cast<float>(scalpel_depth_mm);
    if (ImGui::SliderFloat("scalpel depth, mm", &depth, 2.0f, 60.0f, "%.0f"))
      scalpel_depth_mm = depth;
  }
  if (snap.cuts > 0)
    ImGui::Text("cuts: %d (%lld tetrahedra divided; the last took %.0f ms)", snap.cuts,
                static_cast<long long>(snap.tets_cut), snap.last_cut_ms);
  if (snap.undoable > 0) {
    if (ImGui::Button("Undo cut (U)")) handle_key("u");
    ImGui::SameLine();
    ImGui::Text("%d can be undone", snap.undoable);
  }
  if (!snap.cut_message.empty()) ImGui::TextWrapped("scalpel: %s", snap.cut_message.c_str());
  float gain = static_cast<float>(options.gain_n_per_mm);
  if (ImGui::SliderFloat("drag gain, N/mm", &gain, 0.001f, 0.1f, "%.3f",
                         ImGuiSliderFlags_Logarithmic))
    options.gain_n_per_mm = gain;
  int rung = -1;  // the rate ladder, or auto
  for (size_t k = 0; k < interact::kRateLadder.size(); ++k)
    if (interact::kRateLadder[k] == rate_hz) rung = static_cast<int>(k);
  const std::string label = auto_rate ? "auto" : fmt::format("{:.0f} Hz", rate_hz);
  if (ImGui::BeginCombo("rate", label.c_str())) {
    if (ImGui::Selectable("auto: what this machine keeps", auto_rate)) auto_rate = true;
    for (size_t k = 0; k < interact::kRateLadder.size(); ++k)
      if (ImGui::Selectable(fmt::format("{:.0f} Hz", interact::kRateLadder[k]).c_str(),
                            !auto_rate && rung == static_cast<int>(k))) {
        auto_rate = false;
        rate_hz = interact::kRateLadder[k];
        loop->set_rate(rate_hz);
      }
    ImGui::EndCombo();
  }
  if (ImGui::CollapsingHeader("Body parameters")) body_parameters();
  ImGui::TextDisabled(
      "drag a body: push or pull (Shift: pin); R reset, Space pause, U undo a cut, S picture");
  if (!status.empty()) ImGui::TextWrapped("%s", status.c_str());
  ImGui::End();
}

// One body's material and solver as the loop last published them, changed live
// (world::WorldLoop::set_parameters); the world's dt is every body's.
void WorldViewSession::State::body_parameters() {
  if (snap.bodies.empty()) return;
  param_body = std::clamp(param_body, 0, static_cast<int>(snap.bodies.size()) - 1);
  if (ImGui::BeginCombo("body", snap.bodies[static_cast<size_t>(param_body)].name.c_str())) {
    for (size_t k = 0; k < snap.bodies.size(); ++k)
      if (ImGui::Selectable(snap.bodies[k].name.c_str(), static_cast<int>(k) == param_body))
        param_body = static_cast<int>(k);
    ImGui::EndCombo();
  }
  const world::BodyView& b = snap.bodies[static_cast<size_t>(param_body)];
  sim::Material material = b.material;
  sim::SolverOptions solver = b.solver;
  ImGui::PushID(param_body);  // each body's fields their own
  bool changed = material_widgets(material, last_volume_kpa);
  changed |= solver_widgets(solver, b.solver.dt_s, "dt s (the world's)");
  ImGui::PopID();
  if (b.solver.integrator == sim::Integrator::kImplicitEuler)
    ImGui::Text("CG: %d iterations in the last step, %s", b.stats.sim.cg_iterations,
                b.multigrid ? "multigrid" : "Jacobi");
  if (changed) {
    try {
      // A change of anything but dt keeps the world's, whatever it became since this snapshot.
      loop->set_parameters(b.id, material, solver, b.routing,
                           solver.dt_s == b.solver.dt_s ? world::WorldLoop::Dt::kTheWorlds
                                                        : world::WorldLoop::Dt::kGiven);
      param_error.clear();
    } catch (const Error& e) {
      param_error = e.what();
    }
  }
  if (!param_error.empty())
    ImGui::TextColored(ImVec4(1.0f, 0.45f, 0.3f, 1), "%s", param_error.c_str());
}

void WorldViewSession::State::show() {
  if (snap.generation == shown_generation) return;
  shown_generation = snap.generation;
  constexpr double kMmPerN = 20.0;  // arrows: 1 N draws 20 mm
  for (size_t b = 0; b < snap.bodies.size(); ++b) {
    const world::BodyView& body = snap.bodies[b];
    render::update_positions(body.name, body.x);
    render::Overlays o;
    std::vector<const Force*> forces;  // the pinned ones and the drag, drawn where they act
    for (const Force& f : pinned) forces.push_back(&f);
    if (drag) forces.push_back(&*drag);
    for (const Force* f : forces)
      if (f->body == body.id && f->force.node < body.x.rows()) {
        const Eigen::Vector3d p = body.x.row(f->force.node).transpose();
        o.arrows.push_back({p, p + kMmPerN / 1000.0 * f->force.force_mn});
      }
    // The attachments as beads at each active tie's middle, with the first body: yellow-green
    // at rest to red as they pull.
    if (b == 0)
      for (const world::TieLine& t : snap.ties) {
        const float pull = static_cast<float>(std::clamp(t.pull_mn / 50.0, 0.0, 1.0));
        o.markers.push_back(
            {0.5 * (t.from + t.to), 0.9,
             Eigen::Vector4f(0.75f + 0.25f * pull, 0.85f * (1.0f - pull), 0.2f, 1.0f)});
      }
    render::set_overlays(body.name, std::move(o));
  }
}

void WorldViewSession::State::save_screenshot(const std::string& path, bool with_ui) {
  const std::string p = path.empty() ? fmt::format("lamina_world_{:06d}.png", frames) : path;
  try {
    render::screenshot(p, with_ui);
    screenshots.push_back(p);
    status = "saved " + p;
  } catch (const Error& e) {
    status = e.what();
  }
}

nlohmann::json WorldViewSession::State::report() const {
  using nlohmann::json;
  json bodies = json::array();
  for (size_t b = 0; b < snap.bodies.size(); ++b) {
    const world::BodyView& v = snap.bodies[b];
    bodies.push_back(
        {{"name", v.name},
         {"nodes", v.model->node_count()},
         {"max_displacement_mm", b < max_displacement_mm.size() ? max_displacement_mm[b] : 0.0},
         {"max_penetration_mm", b < max_penetration_mm.size() ? max_penetration_mm[b] : 0.0},
         {"final_displacement_mm", v.stats.sim.max_displacement_mm}});
  }
  return {
      {"scene", scene.source},
      {"world", true},
      {"frames", frames},
      {"steps", snap.steps},
      {"sim_seconds", snap.time_s},
      {"rate_hz", rate_hz},
      {"dt_s", snap.dt_s},
      {"auto_rate", auto_rate},
      {"achieved_rate_hz", snap.rate.achieved_rate_hz},
      {"real_time_factor", snap.rate.real_time_factor},
      {"min_real_time_factor", min_real_time_factor},
      {"keeping_up", snap.rate.keeping_up},
      {"fell_behind", behind_seen},
      {"mean_step_us", snap.rate.mean_step_us},
      {"contact_share_pct",
       contact_share_frames > 0 ? 100.0 * contact_share_sum / contact_share_frames : 0.0},
      {"bodies", bodies},
      {"attachments",
       {{"total", snap.tie_count.total},
        {"divided", snap.tie_count.divided},
        {"torn", snap.tie_count.torn},
        {"divided_by_strokes", snap.ties_divided_by_strokes}}},
      {"drags", drags},
      {"grasps", grasps},
      {"strokes", strokes},
      {"cuts",
       {{"strokes", scalpel_strokes},
        {"bodies_cut", snap.cuts},
        {"tets_divided", snap.tets_cut},
        {"last_cut_ms", snap.last_cut_ms},
        {"message", snap.cut_message}}},
      {"converged", snap.converged},
      {"unstable_events", unstable_events},
      {"first_unstable", first_unstable},
      {"lock_waits", snap.lock_waits},
      {"longest_lock_wait_us", snap.longest_lock_wait_us},
      {"last_press", last_press},
      {"screenshots", screenshots},
  };
}

}  // namespace lamina::cli
