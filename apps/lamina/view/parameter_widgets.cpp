// The material and solver fields of the viewers' panels (parameter_widgets.h).
#include "parameter_widgets.h"

#include <imgui.h>

#include <algorithm>

namespace lamina::cli {

bool material_widgets(sim::Material& material, double& last_volume_kpa) {
  bool changed = false;
  if (material.young_modulus_kpa > 0.0) {
    // The physical tissue in the tetrahedra: E and nu identify every spring and volume term
    // again when they change (a few milliseconds on the paper-size liver).
    changed |=
        ImGui::InputDouble("Young's modulus E kPa", &material.young_modulus_kpa, 0.5, 2, "%.3g");
    changed |=
        ImGui::InputDouble("Poisson's ratio nu", &material.poisson_ratio, 0.01, 0.05, "%.3f");
    int energy = material.tet_model == sim::TetModel::kNeoHookean            ? 2
                 : material.tet_elasticity == model::TetElasticity::kCoupled ? 0
                                                                             : 1;
    if (ImGui::Combo("tetrahedra", &energy,
                     "coupled springs\0independent springs\0stable Neo-Hookean\0")) {
      material.tet_model = energy == 2 ? sim::TetModel::kNeoHookean : sim::TetModel::kSprings;
      if (energy < 2)
        material.tet_elasticity =
            energy == 0 ? model::TetElasticity::kCoupled : model::TetElasticity::kSprings;
      changed = true;
    }
  } else {
    changed |= ImGui::InputDouble("stiffness K N/m", &material.stiffness_n_per_m, 0.5, 5, "%.3f");
  }
  changed |= ImGui::InputDouble("damping gamma kg/s", &material.damping_kg_per_s, 0.5, 5, "%.3f");
  changed |=
      ImGui::InputDouble("node mass kg (0 = lumped)", &material.node_mass_kg, 0.1, 1, "%.4g");
  changed |= ImGui::InputDouble("anchor N/m", &material.anchor_stiffness_n_per_m, 0.1, 1, "%.3f");
  changed |=
      ImGui::InputDouble("mass damping alpha 1/s", &material.mass_damping_per_s, 1, 10, "%.4g");
  // The volume term: 0 is the paper's model; a physical scene starts at lambda - mu.
  bool volume = material.volume_stiffness_kpa > 0.0;
  if (ImGui::Checkbox("volume term", &volume)) {
    material.volume_stiffness_kpa = volume ? std::max(last_volume_kpa, 1e-3) : 0.0;
    changed = true;
  }
  if (volume) {
    changed |=
        ImGui::InputDouble("volume stiffness kPa", &material.volume_stiffness_kpa, 0.5, 5, "%.4g");
    last_volume_kpa = material.volume_stiffness_kpa;
  }
  return changed;
}

bool solver_widgets(sim::SolverOptions& solver, double fixed_dt_s, const char* fixed_dt_label) {
  bool changed = false;
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
  if (fixed_dt_s > 0.0) {
    ImGui::BeginDisabled();
    ImGui::InputDouble(fixed_dt_label, &fixed_dt_s, 0.0, 0.0, "%.4f");
    ImGui::EndDisabled();
  } else {
    changed |= ImGui::InputDouble("dt s", &solver.dt_s, 0.001, 0.01, "%.4f");
  }
  changed |= ImGui::InputDouble("rest speed mm/s", &solver.rest_speed_mm_per_s, 0.0, 0.0, "%.2g");
  changed |= ImGui::InputInt("CG iterations", &solver.cg_max_iterations);
  changed |= ImGui::InputInt("projective iterations", &solver.projective_iterations);
  return changed;
}

}  // namespace lamina::cli
