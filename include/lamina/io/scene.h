#pragma once
/// \file
/// Scene files: what `lamina run` simulates, as one JSON document (layout and every key with its
/// unit and default: docs/scenes.md). Parsing validates everything up front, so a bad scene fails
/// before any model is built or any output written.

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "lamina/interact/scalpel.h"
#include "lamina/interact/tools.h"
#include "lamina/model/build_model.h"
#include "lamina/model/identify_springs.h"
#include "lamina/model/identify_tets.h"
#include "lamina/model/model.h"
#include "lamina/model/surface_support.h"
#include "lamina/sim/simulation.h"

namespace lamina::io {

/// Input name that selects the built-in phantom instead of a mask file.
inline constexpr const char* kScenePhantom = "phantom";

/// A set of nodes held at their rest positions: the nodes within `distance_mm` of a plane, and/or
/// an explicit index list.
struct FixedRegion {
  bool has_plane = false;
  Eigen::Vector3d plane_point_mm = Eigen::Vector3d::Zero();  ///< a point on the plane, mm
  Eigen::Vector3d plane_normal = Eigen::Vector3d::UnitY();   ///< any length, non-zero
  double distance_mm = 10.0;                                 ///< half-thickness of the slab, mm
  std::vector<int32_t> nodes;                                ///< node indices (any layer)
};

/// What `lamina run` writes besides metrics.csv and summary.json.
struct SceneOutput {
  /// Time between frames of the VTK series, s; 0 = only the first and the final state.
  double frame_interval_s = 0.05;
  bool all_layers = false;  ///< a series per layer, not only the skin
  bool obj = false;         ///< OBJ frames beside the .vtp ones
  /// A series per embedded structure of the model (vessels, tumour: `lamina build --embed`) at
  /// W x; false skips them.
  bool embedded = true;
  /// A series of the display skin too, at W x. Off by default: it is the organ's surface at the
  /// mask's resolution, about 2.7 MB of ASCII .vtp a frame on the built-in phantom (36k
  /// triangles) and 7.5 MB on a 512^2 mask (100k): 80-230 MB for the default poke's frames.
  bool display_skin = false;
  /// true: one metrics.csv row per step; false: one per frame.
  bool metrics_every_step = true;
};

/// The physical liver's material as a sim::Material: E and nu carry the stiffness, masses are
/// the model's lumped ones, damping comes from a damping ratio (no per-node gamma).
inline sim::Material physical_material() {
  return {.stiffness_n_per_m = 0.0, .damping_kg_per_s = 0.0, .node_mass_kg = 0.0};
}

/// A parsed scene. Default-constructed, it is the default scene: the physical liver (the
/// phantom filled with tetrahedra; E = 6 kPa, nu = 0.45, critically damped; its posterior
/// surface supported elastically) poked by the paper's tool, stepped at 1 ms by implicit Euler
/// (real time at a haptic device's 1 kHz). paper_scene() is the reference paper's setup.
struct Scene {
  std::string source = "default scene";  ///< the file it came from (names it in messages)

  /// The model: either built from `input` (a mask path or kScenePhantom) with `build`, or loaded
  /// from the saved .vtu `model_path` (then `input` is empty).
  std::string input = kScenePhantom;
  std::string model_path;
  model::BuildOptions build;
  /// True when the scene sets material.density_g_per_cm3: a loaded model's masses are rescaled
  /// to it (they are proportional to the density they were lumped with).
  bool density_given = false;

  sim::Material material = physical_material();
  /// The tissue is physical (the default, and whenever the file gives young_modulus_kpa or no
  /// raw spring constant): on a model with tetrahedra, E and nu go to the tetrahedral network
  /// (sim::Material::young_modulus_kpa; model::identify_tets); on a model built with links,
  /// the springs' constants are identified per kind (model::identify_springs) and the volume
  /// term carries the bulk stiffness they cannot. Masses come from the density, damping from
  /// `damping_ratio` (resolve_material(); docs/physics.md). False: the paper's constants
  /// (stiffness_n_per_m, node_mass_kg and damping_kg_per_s as given).
  bool elastic = true;
  model::ElasticMaterial elastic_material;
  model::TetElasticity tet_elasticity = model::TetElasticity::kCoupled;
  /// material.model: the tetrahedra's energy, "springs" (tet_elasticity) or "neo_hookean".
  sim::TetModel tet_model = sim::TetModel::kSprings;
  /// >= 0: mass-proportional damping that damps the slowest mode at this ratio (1 = critical).
  /// Unset (< 0) with an elastic material and no damping key: 1.
  double damping_ratio = -1.0;
  bool volume_stiffness_given = false;  ///< material.volume_stiffness_kpa was in the file
  bool damping_given = false;           ///< damping_kg_per_s or mass_damping_per_s was
  bool integrator_given = false;        ///< solver.integrator was
  bool structure_given = false;         ///< model.build.structure was
  /// The physical default: implicit Euler at 1 ms (a haptic loop's step; the paper's model
  /// takes the paper's semi-implicit Euler at 10 ms).
  sim::SolverOptions solver = {
      .integrator = sim::Integrator::kImplicitEuler, .dt_s = 0.001, .cg_tolerance = 1e-3};
  /// The physical tissue's: no routing (a tool's load spread over the patch it touches, force
  /// conserved); paper_scene() and the paper's constants take the paper's routing.
  interact::RoutingOptions routing{.routing = interact::Routing::kNone};
  std::vector<interact::Tool> tools;  ///< forces in mN (the file gives newtons)
  /// Scalpels (a "tools" entry {"scalpel": ...}): blades drawn through the organ as the run goes,
  /// cutting its tetrahedra (`lamina run` plays them; interact::advance_scalpels).
  std::vector<interact::Scalpel> scalpels;
  std::vector<FixedRegion> fixed;
  /// Elastic support of parts of the skin (zero-length springs to rest, per unit area).
  std::vector<model::SurfaceSupportOptions> support;
  SceneOutput output;

  /// The file has no "tools" key: resolve_scene_defaults() adds the paper's poke.
  bool default_tool = true;
  /// The file has no "boundary" key: resolve_scene_defaults() supports the posterior surface
  /// elastically (a physical material) or fixes the posterior 10 mm (the paper's).
  bool default_fixed = true;
};

/// The reference paper's setup: the phantom's two layers joined by nearest-node links, K = 3 N/m,
/// gamma = 3 kg/s, unit masses, semi-implicit Euler at dt = 0.01 s, the posterior 10 mm fixed,
/// the paper's poke ("lamina run --paper", the paper's examples, `lamina figures`).
Scene paper_scene();

/// Parses and validates a scene.
/// @param[in] json_text    the scene, JSON (comments allowed)
/// @param[in] source_name  names the scene in messages (normally its path)
/// @return the scene; missing keys take the paper's values (docs/scenes.md); paths are kept as
///   written (load_scene() makes them relative to the scene's folder)
/// \note Throws lamina::Error (kInvalidInput) with the message "SOURCE: KEY.PATH: problem" (or
///   the parser's line and column for malformed JSON) for a wrong type, an out-of-range or
///   non-finite value, a tool with both or neither of point and vertex, and so on. An unknown
///   key is not an error: it is logged as a warning naming its path and ignored.
Scene parse_scene(const std::string& json_text, const std::string& source_name);

/// Reads and parses the scene file at `path`; relative paths in it (model.input, model.model)
/// are taken relative to the folder holding the file.
/// \note Throws lamina::Error (kInvalidInput) naming `path` if it cannot be read, and as
///   parse_scene().
Scene load_scene(const std::string& path);

/// Replaces the defaults that depend on the model with concrete values: without "tools", one
/// tool at the skin node with the smallest y (the anterior surface in LPS) pushing +y
/// (posteriorly) with 0.4 N from 0 to 1 s; without "boundary", the posterior surface supported
/// elastically (a physical material: model::SurfaceSupportOptions' defaults) or the nodes
/// within 10 mm of the plane through the largest y, normal +y (the posterior side), fixed (the
/// paper's constants).
/// @param[in,out] scene  a parsed scene; default_tool and default_fixed are false afterwards
/// @param[in]     model  the model the scene runs on
void resolve_scene_defaults(Scene& scene, const Model& model);

/// Checks the scene against the model it runs on, before anything is simulated: tool vertices
/// are skin nodes, tool points touch the skin at rest, fixed node indices exist, and
/// solver.locality does not exceed the model's rings.
/// \note Throws lamina::Error (kInvalidInput) "SOURCE: tools[i].vertex: ..." and the like.
void check_scene_against_model(const Scene& scene, const Model& model);

/// The fixed nodes of every region of `scene`, sorted and unique.
std::vector<int32_t> fixed_scene_nodes(const Scene& scene, const Model& model);

/// Makes `scene`'s material elastic: spring constants from E and nu (stiffness_n_per_m = 0 keeps
/// the model's, which resolve_material() identifies), the model's lumped masses, and no per-node
/// gamma unless the file gave one (damping then comes from a damping ratio).
void use_elastic_material(Scene& scene);

/// What resolve_material() decided, for logs and the run summary.
struct MaterialReport {
  bool elastic = false;  ///< spring constants came from E and nu
  bool tets = false;     ///< ... through the tetrahedra (else per spring kind)
  model::ElasticMaterial elastic_material;
  model::SpringIdentification identification;  ///< valid when elastic without tetrahedra
  model::TetElasticity tet_elasticity = model::TetElasticity::kCoupled;  ///< with tetrahedra
  sim::TetModel tet_model = sim::TetModel::kSprings;                     ///< with tetrahedra
  double tet_volume_modulus_kpa = 0.0;  ///< the tetrahedra's volume term k_v (with tetrahedra)
  double volume_stiffness_kpa = 0.0;    ///< the volume term in use (0 = off)
  double damping_ratio = -1.0;          ///< the ratio damping was set from (< 0: none)
  double lowest_frequency_hz = 0.0;     ///< omega_1 / 2 pi, when a damping ratio was used
  double mass_damping_per_s = 0.0;      ///< alpha in use
  double explicit_dt_limit_s = 0.0;     ///< semi-implicit Euler is unstable above about this dt
  int32_t supported_nodes = 0;          ///< skin nodes held by the elastic support
  double supported_area_mm2 = 0.0;
};

/// What a scene run measured: the content of `lamina run`'s summary.json.
struct RunSummary {
  std::string scene;            ///< the scene's source
  std::string model;            ///< what the model was built from or loaded from
  bool converged = false;       ///< every tool ended and the model came to rest before max_steps
  bool stopped = false;         ///< stopped early by --stop-after, with a checkpoint to resume from
  bool unstable = false;        ///< stopped because the simulation became unstable (exit code 5)
  std::string unstable_reason;  ///< sim::describe() of why, empty when stable
  int64_t steps = 0;
  double sim_seconds = 0.0;    ///< simulated time, s
  double wall_seconds = 0.0;   ///< the whole run: model, simulation and output, s
  double model_seconds = 0.0;  ///< building or loading the model (rings included), s
  /// Setup, wall seconds per stage: reading, the build's stages (or the rings of a loaded
  /// model), "prepare_scene" (support, material, slowest vibration) and "prepare_solver" (the
  /// simulation made and its solver prepared: the multigrid's hierarchy).
  std::vector<std::pair<std::string, double>> setup_stage_seconds;
  double max_displacement_mm = 0.0;        ///< largest node distance from rest over the run
  double max_abs_volume_change_pct = 0.0;  ///< largest |skin volume change| over the run, %
  double final_rest_error_mm = 0.0;        ///< largest node distance from rest at the end
  double final_volume_change_pct = 0.0;    ///< skin volume change at the end, %
  int64_t recoveries = 0;  ///< steps that hit a non-finite or unbounded state and were redone
  sim::Integrator integrator = sim::Integrator::kSemiImplicitEuler;
  sim::Mode mode = sim::Mode::kGlobal;
  interact::Routing routing = interact::Routing::kNone;  ///< the tools' (routing_name())
  /// implicit Euler's preconditioner as the steps took it ("auto" resolved): "jacobi" or
  /// "multigrid"; empty for the other integrators
  std::string preconditioner;
  double dt_s = 0.0;
  int32_t nodes = 0;
  int64_t springs = 0;
  int32_t layers = 0;
  int32_t fixed_nodes = 0;
  int32_t tools = 0;
  double steps_per_second = 0.0;  ///< steps / total step time (tool routing included)
  double mean_step_us = 0.0;
  double median_step_us = 0.0;
  int32_t frames = 0;  ///< frames in each VTK series
  /// --realtime: steps were paced at rate_hz of wall time (a haptic device's loop).
  bool realtime = false;
  double rate_hz = 0.0;           ///< the target rate (realtime only)
  double achieved_rate_hz = 0.0;  ///< steps / wall time of the stepping loop (realtime only)
  /// Simulated seconds per wall second of the stepping loop (realtime only): 1 in real time.
  double real_time_factor = 0.0;
  bool kept_up = true;           ///< realtime: real_time_factor >= 0.95 (else a warning says so)
  double worst_jitter_us = 0.0;  ///< latest start of a step after its tick (realtime only)
  double p99_jitter_us = 0.0;    ///< 99th percentile of that lateness (realtime only)
  double max_reaction_n = 0.0;   ///< largest |reaction force| of the tissue on the tools, N
  /// The scalpels' cuts (written when the scene has scalpels): cuts that divided tetrahedra,
  /// the tetrahedra divided and nodes added, each cut's update time, the pieces after the last
  /// cut (largest first; empty if nothing was cut), and each structure cut across, when.
  int32_t scalpels = 0;
  int64_t cuts = 0;
  int64_t cut_tets = 0;
  int64_t cut_new_nodes = 0;
  double median_cut_ms = 0.0;
  double max_cut_ms = 0.0;
  std::vector<model::CutPiece> pieces;
  struct StructureCrossed {
    double time_s = 0.0;
    model::StructureCut cut;
  };
  std::vector<StructureCrossed> structures_cut;
  MaterialReport material;  ///< written as the "material" object
};

/// Resolves the scene's material against its model, after resolve_scene_defaults(): with an
/// elastic material, identifies the model's spring constants from E and nu (they replace the
/// model's), turns the volume term on at the bulk stiffness the springs cannot carry (unless
/// the file set volume_stiffness_kpa), chooses implicit Euler (unless the file set an
/// integrator: physical tissue is stiff against its node masses, and semi-implicit Euler would
/// need dt of about a millisecond); with a damping ratio, sets Material::mass_damping_per_s from
/// the model's slowest vibration with the nodes in `fixed` held. Warns if semi-implicit Euler's
/// dt is beyond its stability limit.
/// \note Throws lamina::Error (kInvalidInput) naming the scene for a damping ratio on a model
///   held nowhere.
MaterialReport resolve_material(Scene& scene, Model& model, const std::vector<int32_t>& fixed,
                                const model::SurfaceSupport& support = {});

/// The scene's elastic support on the model (every region of `scene.support`, after
/// resolve_scene_defaults()): empty when it has none.
/// \note Throws lamina::Error (kInvalidInput) naming the scene when a region selects no skin.
model::SurfaceSupport scene_support(const Scene& scene, const Model& model);

/// Everything a scene decides about its model before a simulation starts.
struct SceneSetup {
  std::vector<int32_t> fixed;     ///< fixed nodes, sorted and unique
  model::SurfaceSupport support;  ///< supported nodes and their stiffness (all regions)
  MaterialReport material;
};

/// The one preparation of a scene against its model that every command, the viewer, the soak
/// and validation share: resolve_scene_defaults(), check_scene_against_model(), the fixed and
/// supported nodes, resolve_material().
/// \note Throws lamina::Error (kInvalidInput) as those do.
SceneSetup prepare_scene(Scene& scene, Model& model);

/// A simulation of a prepared scene: its material and solver, its nodes fixed and supported.
sim::Simulation make_scene_simulation(const Scene& scene, const Model& model,
                                      const SceneSetup& setup);

/// One JSON object with every field of `summary` (keys as the field names; nan_detected =
/// recoveries > 0; integrator and mode as the scene file spells them).
std::string run_summary_json(const RunSummary& summary);

/// The scene file's spelling of an integrator ("semi_implicit_euler", "implicit_euler"), of a
/// mode ("global", "local") and of a preconditioner ("auto", "jacobi", "multigrid").
std::string integrator_name(sim::Integrator integrator);
std::string mode_name(sim::Mode mode);
std::string preconditioner_name(sim::Preconditioner preconditioner);
/// The scene file's spelling of a routing: "none" or "paper".
std::string routing_name(interact::Routing routing);
/// "display_skin" or "skin" (solver.touch).
std::string touch_name(interact::Touch touch);
/// The scene file's spelling of a tetrahedral energy (material.model): "springs" or
/// "neo_hookean".
std::string tet_model_name(sim::TetModel model);

}  // namespace lamina::io
