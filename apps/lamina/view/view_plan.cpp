// The resection plane (P; issue 49, docs/viewer.md): a translucent square over the organ, moved
// by a left drag on it (along its normal) or turned by a Shift+left drag; the plan
// (model::plan_on_model: remnant, FLR, each tumour's margin, the vessels it crosses) follows it
// live on the organ's current shape; the tumours and the plane take the margin's colours; X (or
// "Resect") divides the organ along it with the simulated cut.
#include <fmt/format.h>
#include <imgui.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/model/embed_surface.h"
#include "lamina/model/keep_piece.h"
#include "lamina/model/plan_on_model.h"
#include "lamina/render/camera.h"
#include "lamina/render/frame.h"
#include "view_session_state.h"

namespace lamina::cli {
namespace {

constexpr const char* kPlaneName = "resection_plane";
constexpr const char* kBandName = "resection_margin_band";  // the plane within the margin
// The tumours, drawn by the plan in its place while it is on: their triangles within the margin
// of the plane, and the others by their side.
constexpr const char* kTumourBandName = "tumour_within_margin";
constexpr const char* kTumourResectedName = "tumour_resected";
constexpr const char* kTumourRemnantName = "tumour_in_remnant";
constexpr const char* kPlanModels[] = {kPlaneName, kBandName, kTumourBandName, kTumourResectedName,
                                       kTumourRemnantName};

// Registers `mesh` under `name` (drawn in `colour`), or removes the name when it is empty.
void show_mesh(const char* name, const SurfaceMesh& mesh, const Eigen::Vector3f& colour,
               float alpha, bool two_sided) {
  if (mesh.F.rows() == 0) {
    if (render::has_model(name)) render::remove_model(name);
    return;
  }
  render::register_model(name, render::mesh_model(mesh.V, mesh.F, two_sided));
  render::Style st;
  st.organ_color = colour;
  st.skin_alpha = alpha;
  st.inner = render::InnerLayers::kHidden;
  render::set_style(name, st);
}

// Margin colours: divided or inside the wanted margin, left in the remnant, clear.
const Eigen::Vector3f kRed(0.92f, 0.15f, 0.12f), kAmber(0.95f, 0.65f, 0.1f),
    kGreen(0.25f, 0.8f, 0.35f);

// The colour of a tumour's worst piece.
Eigen::Vector3f margin_color(const geometry::TumourMargin& t) {
  if (t.side == "divided" || (t.side == "resected" && !t.clear)) return kRed;
  if (t.side == "remnant") return kAmber;
  return kGreen;
}

}  // namespace

void ViewSession::State::toggle_plan() {
  plan.on = !plan.on;
  if (plan.on) {
    if (!plan.placed) {
      // Through the organ's centre, across its longest extent.
      const Eigen::MatrixX3d& x = snap.x.rows() == vm->model.node_count() ? snap.x : vm->model.X;
      const Eigen::Vector3d lo = x.colwise().minCoeff().transpose(),
                            hi = x.colwise().maxCoeff().transpose();
      plan.point = 0.5 * (lo + hi);
      Eigen::Index axis = 0;
      (hi - lo).maxCoeff(&axis);
      plan.normal = Eigen::Vector3d::Unit(axis);
      plan.size_mm = 1.2 * (hi - lo).norm();
      plan.placed = true;
    }
    plan.looks = style.embedded;
    plan.dirty = true;
  } else {
    for (const char* name : kPlanModels)
      if (render::has_model(name)) render::remove_model(name);
    hide_function();
    style.embedded = plan.looks;
  }
}

void ViewSession::State::update_plan() {
  if (!plan.on) return;
  const bool have_x = snap.x.rows() == vm->model.node_count();
  // The plane moved: plan now. The organ moved: at most 10 times a second.
  const double t = seconds();
  const bool organ_moved = have_x && snap.generation != plan.generation && t - plan.last_s >= 0.1;
  if (!plan.dirty && !organ_moved) return;
  plan.dirty = false;
  plan.generation = snap.generation;
  plan.last_s = t;
  const auto start = Clock::now();
  const Eigen::MatrixX3d& x = have_x ? snap.x : vm->model.X;
  std::vector<const Eigen::MatrixX3d*> embedded_x;
  if (render::has_model(kModelName))
    for (const Eigen::MatrixX3d& e : render::embedded_positions(kModelName))
      embedded_x.push_back(e.rows() > 0 ? &e : nullptr);
  geometry::ResectionOptions o;
  o.margin_mm = plan.margin_mm;
  o.liver = static_cast<geometry::LiverCondition>(plan.liver);
  if (plan.keep == 1) o.keep_point = plan.point + plan.normal;
  if (plan.keep == 2) o.keep_point = plan.point - plan.normal;
  try {
    const geometry::ResectionSurface s = geometry::plane_surface(plan.point, plan.normal);
    // The trees' territories once per topology (a cut or a rebuild changes the tetrahedra).
    if (plan.made.tets != vm->model.tets.size() || plan.made.flows.size() != vm->model.trees.size())
      plan.made = model::model_territories(vm->model);
    plan.report = model::plan_on_model(vm->model, x, s, o, embedded_x, &plan.made);
    plan.error.clear();
  } catch (const Error& e) {
    plan.error = e.what();
  }
  if (plan.error.empty())
    show_function(x, embedded_x);
  else
    hide_function();
  const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  plan.update_ms.push_back(ms);
  ++plan.updates;

  // The square, its band within the margin of a tumour (their current points, a few hundred of
  // each), and the margin colours.
  std::vector<Eigen::Vector3d> tumour_points;
  SurfaceMesh near_plane, resected_side, remnant_side;
  const auto append = [](SurfaceMesh& to, const SurfaceMesh& from) {
    const auto base = static_cast<int>(to.V.rows());
    to.V.conservativeResize(to.V.rows() + from.V.rows(), 3);
    to.V.bottomRows(from.V.rows()) = from.V;
    to.F.conservativeResize(to.F.rows() + from.F.rows(), 3);
    to.F.bottomRows(from.F.rows()) = from.F.array() + base;
  };
  for (size_t s = 0; s < vm->model.embedded.size(); ++s) {
    const EmbeddedSurface& e = vm->model.embedded[s];
    if (e.role != SurfaceRole::kTumour) continue;
    Eigen::MatrixX3d own_positions;
    const Eigen::MatrixX3d* p = s < embedded_x.size() ? embedded_x[s] : nullptr;
    if (p == nullptr) {
      model::embedded_positions(e, x, own_positions);
      p = &own_positions;
    }
    const Eigen::Index step = std::max<Eigen::Index>(1, p->rows() / 400);
    for (Eigen::Index v = 0; v < p->rows(); v += step)
      tumour_points.push_back(p->row(v).transpose());
    // Each triangle by its centre's distance to the plane and side.
    std::vector<bool> near(static_cast<size_t>(e.F.rows())), cut_off(near.size()),
        kept(near.size());
    for (Eigen::Index f = 0; f < e.F.rows(); ++f) {
      const Eigen::Vector3d c =
          (p->row(e.F(f, 0)) + p->row(e.F(f, 1)) + p->row(e.F(f, 2))).transpose() / 3.0;
      const double d = (c - plan.point).dot(plan.normal);
      const auto i = static_cast<size_t>(f);
      if (std::abs(d) < plan.margin_mm)
        near[i] = true;
      else
        ((d > 0.0) == plan.report.remnant_in_front ? kept : cut_off)[i] = true;
    }
    append(near_plane, geometry::triangle_subset(*p, e.F, near));
    append(resected_side, geometry::triangle_subset(*p, e.F, cut_off));
    append(remnant_side, geometry::triangle_subset(*p, e.F, kept));
  }
  show_mesh(kTumourBandName, near_plane, kRed, 1.0f, false);
  show_mesh(kTumourResectedName, resected_side, kGreen, 1.0f, false);
  show_mesh(kTumourRemnantName, remnant_side, kAmber, 1.0f, false);
  SurfaceMesh band, rest;
  geometry::plane_margin_band(geometry::plane_surface(plan.point, plan.normal), plan.point,
                              plan.size_mm, 40, tumour_points, plan.margin_mm, {}, band, rest);
  // The plane: green while every tumour is clear or kept, amber when one is not; the band, red.
  Eigen::Vector3f plane_color = kGreen;
  for (const geometry::TumourMargin& tm : plan.report.tumours)
    if (margin_color(tm) == kRed) plane_color = kAmber;
  if (!plan.error.empty()) plane_color = Eigen::Vector3f(0.6f, 0.6f, 0.6f);
  show_mesh(kPlaneName, rest, plane_color, 0.4f, true);
  show_mesh(kBandName, band, kRed, 0.75f, true);
  // The tumours' own surfaces are hidden while the plan draws them.
  style.embedded = plan.looks;
  for (size_t s = 0; s < vm->model.embedded.size() && s < style.embedded.size(); ++s)
    if (vm->model.embedded[s].role == SurfaceRole::kTumour) style.embedded[s].visible = false;
}

bool ViewSession::State::press_on_plane(const Eigen::Vector3d& origin,
                                        const Eigen::Vector3d& direction) {
  if (!plan.on) return false;
  const double along = direction.dot(plan.normal);
  if (std::abs(along) < 1e-9) return false;
  const double t = (plan.point - origin).dot(plan.normal) / along;
  if (t <= 0.0) return false;
  const Eigen::Vector3d at = origin + t * direction;
  const Eigen::Vector3d off = at - plan.point;
  // Inside the square (its half-width along any in-plane direction at most, loosely: a disc).
  if (off.norm() > 0.5 * plan.size_mm) return false;
  plan.grab = at;
  plan.point_at_press = plan.point;
  plan.normal_at_press = plan.normal;
  ++plan.moves;
  return true;
}

void ViewSession::State::move_plane(const Eigen::Vector2d& drag_px, bool turn) {
  const Eigen::Vector2i size = render::window_size();
  const Eigen::Vector3d d =
      render::drag_in_view_plane(render::camera(), size.y(), plan.grab, drag_px.x(), drag_px.y());
  if (turn) {
    // The normal tips towards the drag: a drag of the square's half-width turns it 45 degrees.
    const Eigen::Vector3d n =
        plan.normal_at_press + d / (0.5 * plan.size_mm) -
        (d / (0.5 * plan.size_mm)).dot(plan.normal_at_press) * plan.normal_at_press;
    if (n.norm() > 1e-9) plan.normal = n.normalized();
    plan.point = plan.point_at_press;
  } else {
    plan.point = plan.point_at_press + d.dot(plan.normal_at_press) * plan.normal_at_press;
  }
  plan.dirty = true;
}

void ViewSession::State::resect_plan() {
  if (!plan.on || !plan.error.empty()) {
    plan_message = plan.on ? "nothing to resect: " + plan.error : "place the plane first (P)";
    return;
  }
  // The blade sweeps the whole square: its path along one side, its depth across the other.
  Eigen::MatrixX3d V;
  Eigen::MatrixX3i F;
  geometry::surface_triangles(geometry::plane_surface(plan.point, plan.normal), plan.point,
                              plan.size_mm, V, F);
  const Eigen::Vector3d a = V.row(0), b = V.row(1), c = V.row(3);
  try {
    loop->cut({a, b}, (c - a).normalized(), (c - a).norm());
  } catch (const Error& e) {
    plan_message = e.what();
    return;
  }
  plan.resected = true;
  plan.awaiting_cut = true;
  plan.remnant_in_front = plan.report.remnant_in_front;
  plan_message =
      fmt::format("resecting: remnant {:.1f} mL ({:.1f}%), resected {:.1f} mL",
                  plan.report.remnant_ml, plan.report.flr_percent, plan.report.resected_ml);
  cut_message = "cutting...";
  log::info("lamina view: {}", plan_message);
  toggle_plan();  // the plane goes; the cut's report follows (adopt_cut)
}

void ViewSession::State::take_away_resected() {
  plan.awaiting_cut = false;
  const Model& cut = vm->model;
  const std::vector<uint8_t> keep =
      model::nodes_of_pieces_on_side(cut, plan.point, plan.normal, plan.remnant_in_front);
  std::vector<int32_t> new_index;
  auto next = std::make_unique<ViewModel>();
  try {
    next->model = model::keep_nodes(cut, keep, new_index);
  } catch (const Error& e) {
    plan_message = std::string("the resected part stays: ") + e.what();
    return;
  }
  // The boundary, by rest position: every copy of a fixed or supported node.
  const auto same = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    return (a - b).squaredNorm() < 1e-18;
  };
  const Eigen::MatrixX3d& X = next->model.X;
  for (Eigen::Index n = 0; n < X.rows(); ++n) {
    const Eigen::Vector3d p = X.row(n).transpose();
    if (std::any_of(fixed_at.begin(), fixed_at.end(), [&](const auto& q) { return same(p, q); }))
      next->fixed.push_back(static_cast<int32_t>(n));
    for (const auto& [q, k] : support_at)
      if (same(p, q)) {
        next->support.nodes.push_back(static_cast<int32_t>(n));
        next->support.stiffness_n_per_m.push_back(k);
        break;
      }
  }
  next->material = material;
  next->source = vm->source;
  const double kept_ml = plan.report.remnant_ml;
  {
    std::lock_guard lock(rebuild_mutex);
    rebuilt = std::move(next);  // swapped in at the next frame, as a rebuild is
  }
  plan_message = fmt::format("resected; the remnant ({:.0f} mL) is simulated on its own", kept_ml);
  log::info("lamina view: {}", plan_message);
}

void ViewSession::State::plan_panel() {
  if (!ImGui::CollapsingHeader("Resection plan", ImGuiTreeNodeFlags_DefaultOpen)) return;
  bool on = plan.on;
  if (ImGui::Checkbox("Plan a resection (P)", &on)) toggle_plan();
  if (!plan_message.empty()) ImGui::TextWrapped("%s", plan_message.c_str());
  if (!plan.on) return;
  ImGui::TextWrapped("Drag the plane to move it, Shift+drag to turn it.");
  plan.dirty |= ImGui::SliderFloat("margin wanted, mm", &plan.margin_mm, 0.0f, 30.0f, "%.0f");
  const char* livers[] = {"normal (20%)", "chemotherapy (30%)", "cirrhosis (40%)"};
  plan.dirty |= ImGui::Combo("liver", &plan.liver, livers, 3);
  const char* keeps[] = {"larger side", "front", "back"};
  plan.dirty |= ImGui::Combo("keep", &plan.keep, keeps, 3);
  if (!plan.error.empty()) {
    ImGui::TextColored(ImVec4(0.9f, 0.4f, 0.3f, 1.0f), "%s", plan.error.c_str());
  } else {
    const geometry::ResectionReport& r = plan.report;
    ImGui::Text("remnant %.0f mL, resected %.0f mL", r.remnant_ml, r.resected_ml);
    const ImVec4 ok(0.4f, 0.9f, 0.45f, 1.0f), bad(0.95f, 0.3f, 0.25f, 1.0f),
        warn(0.95f, 0.7f, 0.2f, 1.0f);
    ImGui::TextColored(r.flr_sufficient ? ok : bad, "FLR %.1f%% (at least %.0f%%)", r.flr_percent,
                       r.flr_threshold_percent);
    for (const geometry::TumourMargin& t : r.tumours) {
      const Eigen::Vector3f c = margin_color(t);
      ImGui::TextColored(c == kRed     ? bad
                         : c == kAmber ? warn
                                       : ok,
                         "%s %d: %s, margin %.1f mm", t.name.c_str(), t.piece, t.side.c_str(),
                         t.margin_mm);
    }
    for (const geometry::StructureCrossing& c : r.crossings)
      ImGui::Text("crosses %s, %.1f mm", c.name.c_str(), c.diameter_mm);
    if (r.remnant_pieces.size() > 1)
      ImGui::TextColored(bad, "remnant in %zu pieces", r.remnant_pieces.size());
    function_panel();
  }
  if (!plan.update_ms.empty())
    ImGui::Text("plan: %.1f ms (%lld updates)", plan.update_ms.back(),
                static_cast<long long>(plan.updates));
  if (ImGui::Button("Resect (X)")) resect_plan();
}

nlohmann::json ViewSession::State::plan_json() const {
  nlohmann::json j;
  j["on"] = plan.on;
  j["resected"] = plan.resected;
  j["point_mm"] = {plan.point.x(), plan.point.y(), plan.point.z()};
  j["normal"] = {plan.normal.x(), plan.normal.y(), plan.normal.z()};
  j["moves"] = plan.moves;
  j["updates"] = plan.updates;
  std::vector<double> ms = plan.update_ms;
  if (!ms.empty()) {
    std::sort(ms.begin(), ms.end());
    j["update_ms_median"] = ms[ms.size() / 2];
    j["update_ms_max"] = ms.back();
  }
  j["error"] = plan.error;
  j["message"] = plan_message;
  j["remnant_ml"] = plan.report.remnant_ml;
  j["resected_ml"] = plan.report.resected_ml;
  j["flr_percent"] = plan.report.flr_percent;
  nlohmann::json tumours = nlohmann::json::array();
  for (const auto& t : plan.report.tumours)
    tumours.push_back({{"name", t.name}, {"side", t.side}, {"margin_mm", t.margin_mm}});
  j["tumours"] = tumours;
  j["crossings"] = plan.report.crossings.size();
  if (plan.report.functional) {
    const geometry::FunctionalRemnant& f = *plan.report.functional;
    j["functional_flr_percent"] = plan.report.functional_flr_percent;
    j["devascularized_ml"] = f.devascularized_ml;
    j["congested_ml"] = f.congested_ml;
    j["shaded_triangles"] = plan.shaded_triangles;
    j["territory_triangles"] = plan.territory_triangles;
  } else {
    j["functional_missing"] = plan.report.functional_missing;
  }
  return j;
}

}  // namespace lamina::cli
