// The plan's functional remnant on the organ (issue 63, docs/viewer.md): while the resection
// plane is shown, the display skin's triangles on the remnant's side whose tissue the plane cuts
// off its portal inflow are shaded dark violet-grey, off its hepatic outflow dark blue-grey
// (both: near black),
// and the others, when asked, take the colour of the portal territory feeding them
// (model::surface_function: the sectors two generations below the trunk). Drawn as meshes
// 0.4 mm outside the skin, so that they never fight it for depth.
#include <imgui.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>

#include "lamina/geometry/resection_surface.h"
#include "lamina/model/embed_surface.h"
#include "view_session_state.h"

namespace lamina::cli {
namespace {

constexpr const char* kShadeNames[] = {"function_devascularized", "function_congested",
                                       "function_both"};
// Dark, against the territories' light colours: violet-grey, blue-grey, near black.
const Eigen::Vector3f kShades[] = {
    {0.3f, 0.24f, 0.38f}, {0.2f, 0.29f, 0.42f}, {0.13f, 0.13f, 0.15f}};
constexpr const char* kTerritoryNames[] = {"territory_0", "territory_1", "territory_2",
                                           "territory_3", "territory_4", "territory_5",
                                           "territory_6", "territory_7"};
// Eight light colours apart from the shades, the hepatic veins' blue, the margins' and each other.
const Eigen::Vector3f kTerritoryColors[] = {
    {0.95f, 0.75f, 0.35f}, {0.4f, 0.8f, 0.6f},  {0.92f, 0.6f, 0.75f}, {0.98f, 0.92f, 0.5f},
    {0.65f, 0.85f, 0.35f}, {0.6f, 0.88f, 0.9f}, {0.78f, 0.7f, 0.95f}, {0.8f, 0.75f, 0.6f}};
constexpr double kLiftMm = 0.4;

void show(const char* name, const SurfaceMesh& mesh, const Eigen::Vector3f& colour) {
  if (mesh.F.rows() == 0) {
    if (render::has_model(name)) render::remove_model(name);
    return;
  }
  render::register_model(name, render::mesh_model(mesh.V, mesh.F));
  render::Style st;
  st.organ_color = colour;
  st.skin_alpha = 0.85f;
  st.inner = render::InnerLayers::kHidden;
  render::set_style(name, st);
}

}  // namespace

void ViewSession::State::hide_function() {
  for (const char* name : kShadeNames)
    if (render::has_model(name)) render::remove_model(name);
  for (const char* name : kTerritoryNames)
    if (render::has_model(name)) render::remove_model(name);
}

void ViewSession::State::show_function(const Eigen::MatrixX3d& x,
                                       const std::vector<const Eigen::MatrixX3d*>& ex) {
  const Model& m = vm->model;
  const int32_t skin = model::display_skin_index(m);
  if (skin < 0 || m.trees.empty() || !plan.report.functional) {
    hide_function();
    plan.shaded_triangles = plan.territory_triangles = 0;
    return;
  }
  const EmbeddedSurface& e = m.embedded[static_cast<size_t>(skin)];
  if (plan.skin_rows != e.V.rows() || plan.skin_seed.size() != m.trees.size()) {
    plan.skin_seed.clear();
    for (const ModelVesselTree& t : m.trees) plan.skin_seed.push_back(model::nearest_seeds(t, e.V));
    plan.skin_rows = e.V.rows();
  }
  Eigen::MatrixX3d own;
  const Eigen::MatrixX3d* P = static_cast<size_t>(skin) < ex.size() ? ex[skin] : nullptr;
  if (P == nullptr) {
    model::embedded_positions(e, x, own);
    P = &own;
  }
  // Each vertex's function under the plan (model::surface_function).
  const std::vector<uint8_t> state =
      model::surface_function(m, plan.skin_seed, *plan.report.functional, *P, plan.point,
                              plan.normal, plan.report.remnant_in_front);
  // Lifted along the vertex normals.
  Eigen::MatrixX3d normal = Eigen::MatrixX3d::Zero(P->rows(), 3);
  for (Eigen::Index f = 0; f < e.F.rows(); ++f) {
    const Eigen::RowVector3d a = P->row(e.F(f, 0)), b = P->row(e.F(f, 1)), c = P->row(e.F(f, 2));
    const Eigen::RowVector3d n = (b - a).cross(c - a);
    for (int k = 0; k < 3; ++k) normal.row(e.F(f, k)) += n;
  }
  Eigen::MatrixX3d lifted = *P;
  for (Eigen::Index v = 0; v < P->rows(); ++v) {
    const double len = normal.row(v).norm();
    if (len > 0.0) lifted.row(v) += kLiftMm / len * normal.row(v);
  }
  // Each triangle by its first vertex.
  std::array<std::vector<bool>, 3> shade;
  std::array<std::vector<bool>, 8> territory;
  for (auto& s : shade) s.assign(static_cast<size_t>(e.F.rows()), false);
  for (auto& s : territory) s.assign(static_cast<size_t>(e.F.rows()), false);
  plan.shaded_triangles = plan.territory_triangles = 0;
  for (Eigen::Index f = 0; f < e.F.rows(); ++f) {
    const uint8_t v = state[static_cast<size_t>(e.F(f, 0))];
    if (v >= model::kShownDevascularized && v <= model::kShownBoth) {
      shade[v - model::kShownDevascularized][static_cast<size_t>(f)] = true;
      ++plan.shaded_triangles;
    } else if (plan.territories && v > model::kOnResectedSide && v < model::kShownDevascularized) {
      territory[v - 1][static_cast<size_t>(f)] = true;
      ++plan.territory_triangles;
    }
  }
  for (size_t k = 0; k < 3; ++k)
    show(kShadeNames[k], geometry::triangle_subset(lifted, e.F, shade[k]), kShades[k]);
  for (size_t k = 0; k < 8; ++k)
    show(kTerritoryNames[k], geometry::triangle_subset(lifted, e.F, territory[k]),
         kTerritoryColors[k]);
}

void ViewSession::State::function_panel() {
  const geometry::ResectionReport& r = plan.report;
  if (!r.functional) {
    if (!r.functional_missing.empty())
      ImGui::TextWrapped("functional remnant: not assessed (%s)", r.functional_missing.c_str());
    return;
  }
  const geometry::FunctionalRemnant& f = *r.functional;
  const ImVec4 ok(0.4f, 0.9f, 0.45f, 1.0f), bad(0.95f, 0.3f, 0.25f, 1.0f);
  ImGui::TextColored(r.functional_sufficient ? ok : bad, "functional FLR %.1f%% (%.0f mL)",
                     r.functional_flr_percent, f.functional_ml);
  const auto swatch = [](const Eigen::Vector3f& c) {
    ImGui::ColorButton("##shade", ImVec4(c[0], c[1], c[2], 1.0f), ImGuiColorEditFlags_NoTooltip,
                       ImVec2(12, 12));
    ImGui::SameLine();
  };
  if (f.portal) {
    swatch(kShades[0]);
    ImGui::Text("devascularized %.0f mL", f.devascularized_ml);
  }
  if (f.hepatic) {
    swatch(kShades[1]);
    ImGui::Text("congested %.0f mL", f.congested_ml);
  }
  for (const geometry::TreeFate& t : f.trees)
    if (t.divided > 0) ImGui::Text("%s: %d branch(es) divided", t.name.c_str(), t.divided);
  if (ImGui::Checkbox("portal territories", &plan.territories)) plan.dirty = true;
}

}  // namespace lamina::cli
