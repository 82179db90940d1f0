#pragma once
/// \file
/// Mass-spring dynamics of a Model: m x'' + gamma x' + f_springs(x) = f_ext (the paper's eq. 4).
/// Plain structs and one step() call, in the manner of Box2D: make_simulation() once, step()
/// every frame. Units: mm, kg, s; forces in mN (kg mm / s^2), stiffness in N/m (= mN/mm).

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "lamina/model/model.h"

namespace lamina::sim {
namespace detail {
struct ProjectiveSolver;  // projective.cpp: the prefactored system, reused across steps
}

/// Time integrators.
enum class Integrator : uint8_t {
  kSemiImplicitEuler,  ///< the paper's: v += dt a(x, v); x += dt v. Cheap; stable only for small dt
  kImplicitEuler,      ///< backward Euler, one linearised solve by conjugate gradients per step
  /// projective dynamics, the "fast mass-spring" method of Liu et al. 2013: backward Euler's
  /// nonlinear system by a fixed number of local (project each spring to its rest length) and
  /// global (one prefactored sparse solve) iterations. The factor is reused while dt, the
  /// material and the movable nodes stay the same.
  kProjective,
};

/// Which nodes move.
enum class Mode : uint8_t {
  kGlobal,  ///< every free node
  kLocal,   ///< the paper's: only the nodes set with set_local_nodes(); the rest are held
};

/// Tissue parameters. Defaults are the reference paper's (K = 3, gamma = 3, unit node masses).
struct Material {
  /// > 0: every spring gets this Hooke constant (the paper's K), N/m. 0: keep the model's.
  double stiffness_n_per_m = 3.0;
  /// gamma: viscous damping per node, kg/s (force = -gamma v, mN for v in mm/s).
  double damping_kg_per_s = 3.0;
  /// alpha: mass-proportional damping, 1/s: each node also feels -alpha m v (the mass term of
  /// Rayleigh damping). With physical lumped masses, which differ from node to node, this damps
  /// every node at the same rate; model::damping_for_ratio() derives it from a damping ratio.
  double mass_damping_per_s = 0.0;
  /// > 0: every node has this mass, kg (the paper uses unit masses). 0: the model's lumped
  /// masses from density and volume.
  double node_mass_kg = 1.0;
  /// > 0: every free node is tied to its rest position by a spring of this stiffness, N/m
  /// (support from the surrounding tissue).
  double anchor_stiffness_n_per_m = 0.0;
  /// K_v > 0 turns the volume term on: each region between neighbouring layers (and the core
  /// inside the deepest layer) resists a change of its volume as a fluid of bulk modulus K_v,
  /// kPa (= mN/mm^2): energy K_v (V - V0)^2 / (2 V0), pressure K_v (V - V0) / V0 on the layers
  /// that bound it (after Teschner et al. 2004; docs/physics.md). 0 = off (the paper's model).
  double volume_stiffness_kpa = 0.0;
  /// Gravity, mm/s^2 (Earth: 9810 along -z in LPS for a supine patient is (0, 9810, 0)).
  Eigen::Vector3d gravity_mm_per_s2 = Eigen::Vector3d::Zero();
};

/// Solver parameters. Defaults are the paper's (dt = 0.01 s, threshold 1e-3 mm).
struct SolverOptions {
  Integrator integrator = Integrator::kSemiImplicitEuler;
  double dt_s = 0.01;          ///< time step, s, > 0
  double threshold_mm = 1e-3;  ///< converged when no node moves more than this in one step
  int64_t max_steps = 100000;  ///< run_to_convergence() gives up after this many steps
  Mode mode = Mode::kGlobal;
  int32_t cg_max_iterations = 100;  ///< implicit Euler: CG iterations per step at most
  /// implicit Euler: CG stops at ||b - A dv|| <= cg_tolerance ||b|| (warm-started from the last
  /// step's dv, which a smooth motion changes little)
  double cg_tolerance = 1e-6;
  int32_t projective_iterations = 10;  ///< projective dynamics: local/global iterations per step
};

/// What one step measured. Valid until the next step.
struct StepStats {
  double max_move_mm = 0.0;          ///< largest node move in this step (the convergence test)
  double max_displacement_mm = 0.0;  ///< largest distance of a node from its rest position
  double skin_volume_mm3 = 0.0;      ///< volume enclosed by the deformed skin (layer 0)
  double volume_change_pct = 0.0;    ///< 100 (V - V_rest) / V_rest
  double kinetic_energy_j = 0.0;     ///< 1/2 sum m v^2, joules
  double step_us = 0.0;              ///< wall time of the step, microseconds
  int32_t cg_iterations = 0;         ///< implicit Euler only
  bool converged = false;            ///< max_move_mm < threshold
  bool recovered = false;            ///< a non-finite state was rolled back and the step redone
  /// Not even backward Euler could take the step: the state was kept, the motion stopped, and
  /// the step does not count as converged (a load or dt far beyond what the model can take).
  bool failed = false;
};

/// The simulation: the model it runs on (not owned: it must outlive the simulation), its
/// parameters, and structure-of-arrays state and workspace. Create with make_simulation().
///
/// A step costs in proportion to the movable nodes and their springs, not to the model: in local
/// mode a poke on a 100k-node model steps only the nodes it reaches. Nodes that do not move keep
/// their positions; write them only through make_simulation(), fix_nodes(), set_local_nodes(),
/// set_parameters() or reset(), which also refresh what the measurements cache about them.
struct Simulation {
  const Model* model = nullptr;
  Material material;
  SolverOptions options;

  // State (#nodes by 3, column-major: x, y, z each contiguous).
  Eigen::MatrixX3d x;      ///< positions, mm
  Eigen::MatrixX3d v;      ///< velocities, mm/s
  Eigen::MatrixX3d f_ext;  ///< external (tool) forces, mN; set by the caller before step()
  double time_s = 0.0;
  int64_t steps = 0;
  int64_t recoveries = 0;  ///< steps that hit a non-finite state and were redone

  // Per node.
  std::vector<double> mass_kg;
  std::vector<uint8_t> fixed;    ///< 1 = held at its rest position (boundary condition)
  std::vector<uint8_t> movable;  ///< 1 = integrated this step (not fixed, and local when kLocal)

  // Springs gathered per node (CSR), so each thread writes only its own nodes' forces.
  std::vector<int32_t> adj_offsets;       ///< #nodes + 1
  std::vector<int32_t> adj_other;         ///< the node at the other end
  std::vector<int32_t> adj_spring;        ///< the spring index
  std::vector<int32_t> adj_signed;        ///< e where the node is spring e's first end, ~e else
  std::vector<double> stiffness_n_per_m;  ///< per spring, after Material::stiffness_n_per_m
  double rest_skin_volume_mm3 = 0.0;
  std::vector<double> rest_layer_volume_mm3;  ///< per layer: the volume it encloses at rest
  /// A node this far from its rest position (100 model sizes) counts as a blow-up.
  double blowup_limit_mm = 0.0;

  /// Counts changes of what a prefactored solve depends on (movable nodes, material, dt).
  uint64_t setup_version = 0;
  /// explicit_dt_limit(), cached for the setup_version it was computed at (0 = not yet).
  double explicit_limit_s = 0.0;
  uint64_t explicit_limit_version = 0;
  std::shared_ptr<detail::ProjectiveSolver> projective;  ///< made on the first projective step

  // What a step visits: the movable nodes (ascending) and every spring with a movable end.
  std::vector<int32_t> active_nodes;
  std::vector<int32_t> active_springs;
  // What the nodes that do not move add to the measurements, cached when the lists change.
  double frozen_max_displacement_mm = 0.0;
  /// Per layer: its triangles with a movable corner, and 6 x the signed volume of the others.
  std::vector<std::vector<int32_t>> layer_triangles;
  std::vector<double> frozen_layer_volume6_mm3;

  // Volume term (Material::volume_stiffness_kpa > 0). Each node's layer triangles as the two
  // corners that follow it (CSR, 2 per triangle): the gradient of its layer's volume is
  // 1/6 sum x_b x x_c over them.
  std::vector<int32_t> corner_offsets;  ///< #nodes + 1
  std::vector<int32_t> corner_pairs;
  std::vector<double> pressure_jump_kpa;  ///< per layer: pressure inside minus outside it
  Eigen::MatrixX3d volume_gradient;       ///< per movable node: d(its layer's volume)/dx, mm^2

  // Workspace, sized once (no allocation per step). Rows of nodes that do not move stay zero in
  // r, z, p, dv: the implicit solve treats them as held.
  Eigen::MatrixX3d spring_force;     ///< per spring: its Hooke force on its first node, mN
  Eigen::MatrixX3d x_prev, v_prev;   ///< the movable nodes' state before the step (rollback)
  Eigen::MatrixX3d r, p, z, y, dv;   ///< implicit Euler: conjugate gradients; dv warm-starts
  Eigen::MatrixX3d diag;             ///< Jacobi preconditioner (per node, per axis)
  /// Per spring, for implicit Euler's stiffness matrix: unit direction and max(0, 1 - L/l), in
  /// single precision (it only steers the solve; docs/benchmarks.md has the measurement).
  Eigen::Matrix<float, Eigen::Dynamic, 4, Eigen::RowMajor> dir;
};

/// Checks material and solver parameters (make_simulation() and set_parameters() call it).
/// \note Throws lamina::Error (kInvalidInput) naming the parameter: non-positive dt or
///   threshold, negative stiffness, damping, mass or anchor, non-finite gravity, and so on.
void check_parameters(const Material& material, const SolverOptions& options);

/// Sets up a simulation of `model` at rest.
/// \note Throws lamina::Error (kInvalidInput) naming the parameter for non-positive dt,
///   negative stiffness or damping, and so on.
Simulation make_simulation(const Model& model, const Material& material = {},
                           const SolverOptions& options = {});

/// Changes material and solver parameters of a running simulation, keeping its state (positions,
/// velocities, time, fixed nodes). Switching to global mode makes every free node movable;
/// switching to local mode keeps only the currently movable ones (set_local_nodes() adds more).
/// \note Throws lamina::Error (kInvalidInput) as make_simulation(); `sim` is then unchanged.
void set_parameters(Simulation& sim, const Material& material, const SolverOptions& options);

/// Holds these nodes at their rest positions from now on (a region of the skin attached to
/// surrounding anatomy). Without fixed nodes or anchor springs a pushed model drifts as a rigid
/// body and cannot return to rest.
void fix_nodes(Simulation& sim, const std::vector<int32_t>& nodes);

/// Holds these nodes at the given positions from now on (a displacement-controlled indenter, a
/// clamp that has moved them): like fix_nodes(), but at `positions` (one row per node, mm)
/// instead of their rest positions. Calling it again moves them on.
/// \note Throws lamina::Error (kInvalidInput) for a node outside the model, a row count that
///   differs from the node count, or a non-finite position.
void hold_nodes(Simulation& sim, const std::vector<int32_t>& nodes,
                const Eigen::MatrixX3d& positions);

/// Lets these nodes move again from where they are held (releases an indenter or a clamp): they
/// become free, at rest velocity, and movable unless local mode has not made them so.
/// \note Throws lamina::Error (kInvalidInput) for a node outside the model.
void release_nodes(Simulation& sim, const std::vector<int32_t>& nodes);

/// Nodes within `distance_mm` of the plane through `point` with normal `normal` (any length).
std::vector<int32_t> nodes_near_plane(const Model& model, const Eigen::Vector3d& point,
                                      const Eigen::Vector3d& normal, double distance_mm);

/// Local mode: only these nodes move (besides being free); every other node is held where it is.
void set_local_nodes(Simulation& sim, const std::vector<int32_t>& nodes);

/// Puts every node back at rest (x = X, v = 0, time 0), keeping parameters and fixed nodes.
void reset(Simulation& sim);

/// Everything step() carries from one step to the next: restoring it into a simulation made
/// with the same model, material and options continues the run bit for bit (a checkpoint).
struct SimState {
  Eigen::MatrixX3d x, v, f_ext;
  Eigen::MatrixX3d dv;  ///< implicit Euler's warm start: the last step's velocity change
  double time_s = 0.0;
  int64_t steps = 0;
  int64_t recoveries = 0;
  std::vector<uint8_t> fixed, movable;
};

/// Copies the state of `sim` (for a checkpoint).
SimState capture_state(const Simulation& sim);

/// Puts a captured state back into `sim`, which must run the same model.
/// \note Throws lamina::Error (kInvalidInput) naming the problem if the state's sizes disagree
///   with the model, a value is not finite or a flag is not 0 or 1; `sim` is then unchanged.
void restore_state(Simulation& sim, const SimState& state);

/// Advances one time step: spring, damping, anchor, gravity and external forces; integrate
/// (semi-implicit Euler in explicit_substeps() equal parts when dt is beyond its limit);
/// check every value is finite (else roll back and redo the step with two half steps, then with
/// implicit Euler; if that fails too, keep the state, stop the motion and report `failed`);
/// measure.
StepStats step(Simulation& sim);

/// Steps until converged for `quiet_steps` consecutive steps, or options.max_steps. One quiet
/// step is not enough: a model just poked moves less than the threshold in its first steps, and
/// velocities pass through zero at every turn of an oscillation.
/// @return the stats of the last step (converged is true only if the quiet window was reached)
StepStats run_to_convergence(Simulation& sim, int64_t quiet_steps = 10);

/// Adds the spring forces at positions x (#nodes by 3, mm) to f (mN): the step's own two passes
/// (each spring once, then each node sums its springs) over every spring, with sim's workspace.
/// Forces sum to zero (Newton's third law).
void spring_forces(Simulation& sim, const Eigen::MatrixX3d& x, Eigen::MatrixX3d& f);

/// The implicit system's product y = (M + h gamma + h^2 K) p on the movable nodes (rows of other
/// nodes get 0), with K linearised by the last implicit step (one conjugate-gradient iteration's
/// main cost; public for benchmarks).
void implicit_system_product(const Simulation& sim, double h, const Eigen::MatrixX3d& p,
                             Eigen::MatrixX3d& y);

/// Volume enclosed by layer `layer` of the model at positions x, mm^3.
double layer_volume(const Model& model, const Eigen::MatrixX3d& x, int32_t layer = 0);

/// omega_1, rad/s: the slowest natural frequency of the model about its rest shape, with its
/// held nodes and anchors and the current masses and stiffness (inverse iteration on a sparse
/// factorization; the volume term is left out). Mass-proportional damping
/// Material::mass_damping_per_s = 2 zeta omega_1 damps that mode at damping ratio zeta.
/// \note Throws lamina::Error (kInvalidInput) if the model is held nowhere (its slowest motion
///   is a free drift) or everywhere.
double lowest_angular_frequency(const Simulation& sim, int32_t max_iterations = 300);

/// Semi-implicit Euler's stability limit for this simulation's masses, stiffness and damping,
/// s: the largest dt with h^2 w^2 + 2 h c < 4 at every node, w^2 Gershgorin's bound on the
/// node's row of M^-1 K (springs, anchor and the volume term's rank-one stiffness at rest) and
/// c its damping rate. A safe (low) estimate: Gershgorin bounds w from above. step() splits a
/// semi-implicit Euler step longer than 0.9 of it into equal substeps, so a physical material
/// at a large dt costs more steps instead of blowing up.
double explicit_dt_limit(const Simulation& sim);

/// How many substeps step() splits a semi-implicit Euler step of dt_s into, given the limit.
inline int64_t explicit_substeps(double dt_s, double limit_s) {
  const double safe = 0.9 * limit_s;
  return dt_s > safe ? static_cast<int64_t>(std::ceil(dt_s / safe)) : 1;
}

/// Total elastic energy of the springs at positions x, joules.
double spring_energy(const Simulation& sim, const Eigen::MatrixX3d& x);

/// Every stored energy at positions x, joules: springs, anchor springs and the volume term.
double elastic_energy(const Simulation& sim, const Eigen::MatrixX3d& x);

/// The volume term's forces at positions x added to f (mN), for every node (zero when the term
/// is off): minus the gradient of its energy.
void volume_forces(Simulation& sim, const Eigen::MatrixX3d& x, Eigen::MatrixX3d& f);

}  // namespace lamina::sim
