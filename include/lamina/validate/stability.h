#pragma once
/// \file
/// The stability suite: large indentations, pulls and several tools at once, under each
/// integrator over a sweep of time steps; each case loads the model, releases it and runs it back
/// to rest, checking that every state stays finite, that no inner layer crosses outside its outer
/// layer, that the energy decays after the release and that the model returns to rest
/// (docs/validation.md, "Stability").

#include <cstdint>
#include <string>
#include <vector>

#include "lamina/model/model.h"
#include "lamina/model/surface_support.h"
#include "lamina/sim/simulation.h"
#include "lamina/validate/indentation.h"

namespace lamina::validate {

/// Whether the layers are still nested, and the tetrahedra upright, at positions x.
struct LayerOrder {
  int64_t outside_nodes = 0;    ///< nodes of inner layers on or outside the layer around them
  bool surfaces_cross = false;  ///< some layer's surface crosses the one around it
  int64_t inverted_tets = 0;    ///< tetrahedra with volume <= 0
  bool ordered() const { return outside_nodes == 0 && !surfaces_cross && inverted_tets == 0; }
};
/// Checks each layer against the one around it at positions x (#nodes by 3, mm), as
/// model::build_model() checks them at rest (CGAL: point in mesh, surface intersection), and
/// counts inverted tetrahedra.
LayerOrder check_layer_order(const Model& model, const Eigen::MatrixX3d& x);

/// How a case loads the model.
enum class LoadKind : uint8_t {
  kIndent,  ///< the indenter's skin patch held at depth along the indentation direction
  kPull,    ///< the same patch held at depth against it (pulled out of the organ)
  kTools,   ///< several of the paper's force tools at once (routed over rings and crossings)
};

/// One case of the suite.
struct StabilityCase {
  std::string name;  ///< e.g. "indent 50%", "3 tools 1 N"
  LoadKind kind = LoadKind::kIndent;
  double depth_fraction = 0.0;  ///< indent, pull: of the organ's depth along the direction
  int32_t tool_count = 0;       ///< tools: how many (1..3)
  double tool_force_n = 0.0;    ///< tools: each tool's total routed load, N
  sim::Integrator integrator = sim::Integrator::kImplicitEuler;
  double dt_s = 0.01;
};

/// What the checks require.
struct StabilityOptions {
  double rest_tolerance_mm = 0.05;  ///< after the release, no node farther than this from rest
  /// After the release the energy may rise above its value at the release by this fraction at
  /// most (a symplectic integrator's energy wobbles within a step; it must not grow).
  double energy_rise_tolerance = 0.02;
  double final_energy_fraction = 1e-3;  ///< ... and must end below this fraction of it
  double rest_speed_mm_per_s = 0.01;    ///< at rest: no node faster than this
  double rest_window_s = 0.1;           ///< ... for this long
  double check_interval_s = 0.05;       ///< layer order checked this often (and at each stage)
  double ramp_s = 2.0;  ///< an indentation or pull moves in at a steady speed over this time
  int64_t max_steps_per_stage = 20000;  ///< a stage that has not come to rest by then fails
};

/// What one case measured.
struct StabilityResult {
  StabilityCase c;
  bool finite = true;      ///< every state finite (after any rollback)
  int64_t recoveries = 0;  ///< steps that went non-finite and were rolled back and redone
  sim::Instability unstable = sim::Instability::kNone;  ///< the watch's verdict (step())
  /// The worst of the checks at rest (under the load, and after the release): most nodes
  /// outside, whether surfaces cross, most tetrahedra inverted. The pass criterion.
  LayerOrder order;
  /// The same while moving (every check_interval_s): reported, not required (an indenter's rim
  /// can flatten a tetrahedron under it for a moment).
  LayerOrder order_in_motion;
  int32_t order_checks = 0;  ///< how many times the layer order was checked
  double peak_displacement_mm = 0.0;
  double peak_volume_change_pct = 0.0;  ///< of the skin's enclosed volume, largest |change|
  bool loaded_at_rest = false;          ///< the loaded model came to rest
  double release_energy_j = 0.0;        ///< kinetic + elastic at the release
  double max_energy_j = 0.0;            ///< the largest after the release
  double final_energy_j = 0.0;
  bool returned_at_rest = false;  ///< the released model came to rest
  double rest_error_mm = 0.0;     ///< largest distance from rest at the end
  int64_t steps = 0;
  double seconds = 0.0;
  /// Energy after the release, sampled each step: (time since release s, J), for the plot.
  std::vector<std::pair<double, double>> energy_trace;

  /// The largest energy after the release over the energy at the release, minus 1.
  double energy_rise() const;
  bool energy_decays(const StabilityOptions& o) const;
  bool passed(const StabilityOptions& o) const;
  /// Why the case did not pass: each check it missed, in one line ("" when it passed), e.g.
  /// "unstable at step 73 (...); no rest under the load".
  std::string failure(const StabilityOptions& o) const;
};

/// The suite: indentations to 10..50% of the organ's depth and pulls to 10..30% under implicit
/// Euler at `dt_s`; one, two and three tools; a 30% indentation under each integrator at
/// 0.1, 0.3, 1, 3 and 10 times `dt_s` (implicit Euler's 1x is the load case; projective
/// dynamics only when `projective`: it does not carry the tetrahedra's elasticity). Names are
/// unique per integrator and dt. `quick`: the deepest indentation and pull, three tools, the
/// 10x step under implicit Euler, and the 10x step under projective dynamics (or, without it,
/// the 0.1x step under semi-implicit Euler).
std::vector<StabilityCase> stability_cases(double dt_s, bool quick, bool projective = true);

/// Runs one case on `model`: its held region (`indentation`'s slab) fixed and `support` (the
/// scene's elastic support, model::surface_support(); may be empty) tying the skin it names, the
/// load applied and run to rest, released and run to rest again. Gravity is left out (rest is
/// the model's rest shape). The material and solver options are the scene's; the case sets
/// integrator and dt.
/// \note Throws lamina::Error (kInvalidInput) if the indenter's patch holds no skin node or a
///   tool touches nothing.
StabilityResult run_stability_case(const Model& model, const sim::Material& material,
                                   const sim::SolverOptions& solver, const Indentation& indentation,
                                   const StabilityCase& c, const StabilityOptions& options = {},
                                   const model::SurfaceSupport& support = {});

}  // namespace lamina::validate
