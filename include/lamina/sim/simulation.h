#pragma once
/// \file
/// Dynamics of a Model: m x'' + gamma x' + f_internal(x) = f_ext (the paper's eq. 4), with
/// f_internal from the springs, the tetrahedra, the volume term and the support.
/// Plain structs and one step() call, in the manner of Box2D: make_simulation() once, step()
/// every frame. Units: mm, kg, s; forces in mN (kg mm / s^2), stiffness in N/m (= mN/mm).

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "lamina/model/identify_tets.h"
#include "lamina/model/model.h"

namespace lamina::sim {
namespace detail {
struct Solver;  // solver.h: the simulation's caches and workspace, private to module sim
}

/// Time integrators.
enum class Integrator : uint8_t {
  kSemiImplicitEuler,  ///< the paper's: v += dt a(x, v); x += dt v. Cheap; stable only for small dt
  /// backward Euler, one linearised solve by conjugate gradients per step (at most
  /// SolverOptions::cg_max_iterations products: a bounded cost), stable at any dt
  kImplicitEuler,
  /// projective dynamics, the "fast mass-spring" method of Liu et al. 2013: backward Euler's
  /// nonlinear system by a fixed number of local (project each spring to its rest length) and
  /// global (one prefactored sparse solve) iterations. Springs and the volume term between
  /// layers only: not for the tetrahedra's elasticity.
  kProjective,
};

/// Implicit Euler's preconditioner for conjugate gradients.
enum class Preconditioner : uint8_t {
  /// Jacobi or the multigrid, chosen when the solver is prepared (and again when dt, the
  /// material or the movable nodes change) by a trial solve of the system at rest with Jacobi:
  /// the multigrid when that takes 50 iterations or more (docs/benchmarks.md)
  kAuto,
  kJacobi,  ///< the system's diagonal: cheapest per iteration; iterations grow with the mesh
  /// aggregation multigrid (the same organ at coarser scales), built from the system at rest
  /// and again from a step's when the deformation has moved it: 2-6x fewer iterations than
  /// Jacobi at 10 ms from 2k to 48k nodes, three products an iteration, a setup of 1.1 s at 48k
  /// nodes whenever dt, the material or the movable nodes change
  kMultigrid,
};

/// Which nodes move.
enum class Mode : uint8_t {
  kGlobal,  ///< every free node
  kLocal,   ///< the paper's: only the nodes set with set_local_nodes(); the rest are held
};

/// Tissue parameters. Defaults are the reference paper's (K = 3, gamma = 3, unit node masses).
/// What a tetrahedron stores (Material::tet_model).
enum class TetModel : uint8_t {
  /// Its six edge springs, coupled (or not: Material::tet_elasticity), and its signed volume:
  /// linear elasticity at small strain (model::identify_tets).
  kSprings,
  /// Stable Neo-Hookean (Smith, de Goes & Kim 2018): mu/2 (tr C - 3) + lambda'/2 (J - alpha)^2
  /// with lambda' = lambda + mu, alpha = 1 + mu / lambda': linear elasticity at small strain,
  /// hyperelastic at large, and the volume carried by J.
  kNeoHookean,
};

struct Material {
  /// > 0: every spring gets this Hooke constant (the paper's K), N/m. 0: keep the model's (or,
  /// with young_modulus_kpa, the tetrahedra's identified constants).
  double stiffness_n_per_m = 3.0;
  /// gamma: viscous damping per node, kg/s (force = -gamma v, mN for v in mm/s).
  double damping_kg_per_s = 3.0;
  /// alpha: mass-proportional damping, 1/s: each node also feels -alpha m v (the mass term of
  /// Rayleigh damping). With physical lumped masses, which differ from node to node, this damps
  /// every node at the same rate; lowest_angular_frequency() derives it from a damping ratio.
  double mass_damping_per_s = 0.0;
  /// > 0: every node has this mass, kg (the paper uses unit masses). 0: the model's lumped
  /// masses from density and volume.
  double node_mass_kg = 1.0;
  /// > 0: every free node is tied to its rest position by a spring of this stiffness, N/m.
  double anchor_stiffness_n_per_m = 0.0;
  /// K_v > 0 turns the volume term between layers on: each region between neighbouring layers
  /// (and the core inside the deepest layer) resists a change of its volume as a fluid of bulk
  /// modulus K_v, kPa (= mN/mm^2): energy K_v (V - V0)^2 / (2 V0) (after Teschner et al. 2004;
  /// docs/physics.md). 0 = off (the paper's model). The tetrahedra carry their own.
  double volume_stiffness_kpa = 0.0;
  /// E > 0, kPa, on a model with tetrahedra: the tissue's elasticity in the tetrahedral network.
  /// The springs (the tetrahedra's edges) get constants identified from E and nu, coupled within
  /// each tetrahedron, and each tetrahedron resists a change of its signed volume, inverted
  /// ones included (model::identify_tets; docs/physics.md). 0 = off (the springs' own K).
  double young_modulus_kpa = 0.0;
  double poisson_ratio = 0.45;  ///< nu in [0, 0.5), with young_modulus_kpa
  model::TetElasticity tet_elasticity = model::TetElasticity::kCoupled;
  /// With young_modulus_kpa: the tetrahedra's energy, their springs (tet_elasticity) or stable
  /// Neo-Hookean (docs/physics.md).
  TetModel tet_model = TetModel::kSprings;
  /// Gravity, mm/s^2 (Earth: 9810 along -z in LPS for a supine patient is (0, 9810, 0)).
  Eigen::Vector3d gravity_mm_per_s2 = Eigen::Vector3d::Zero();
};

/// Solver parameters. Defaults are the paper's (dt = 0.01 s, and at rest when no node moves
/// more than 1e-3 mm in a 0.01 s step).
struct SolverOptions {
  Integrator integrator = Integrator::kSemiImplicitEuler;
  double dt_s = 0.01;  ///< time step, s, > 0
  /// At rest when no node moves faster than this, mm/s: a speed, so that "at rest" does not
  /// depend on dt (the paper's 1e-3 mm per 0.01 s step is 0.1 mm/s).
  double rest_speed_mm_per_s = 0.1;
  int64_t max_steps = 100000;  ///< run_to_convergence() gives up after this many steps
  Mode mode = Mode::kGlobal;
  int32_t cg_max_iterations = 100;  ///< implicit Euler: CG iterations per step at most
  /// implicit Euler: CG stops at ||b - A dv|| <= cg_tolerance ||b|| (warm-started from the last
  /// step's dv, which a smooth motion changes little)
  double cg_tolerance = 1e-6;
  Preconditioner preconditioner = Preconditioner::kAuto;  ///< implicit Euler's, for CG
  int32_t projective_iterations = 10;  ///< projective dynamics: local/global iterations per step
};

/// Why a simulation stopped being trustworthy (StepStats::unstable). step() latches the first
/// reason it finds and reports it on every later step, until reset() or restore_state().
enum class Instability : uint8_t {
  kNone,
  /// kFailedStepsToUnstable steps in a row could not be taken even by backward Euler: a value
  /// became non-finite or a node moved farther from rest than twice the organ's own size.
  kStepsFailed,
  /// The total energy (kinetic, elastic, gravity's) grew while no tool acted: by more than its
  /// own size since the check began, which damped tissue can never do.
  kEnergyGrowth,
  /// Implicit Euler's conjugate gradients ended more than 100 times above their tolerance
  /// kUnsolvedStepsToUnstable steps in a row: the motion is no longer the integrator's.
  kSolverStalled,
};

/// A one-line reason, for messages ("the energy grew while no tool acted").
const char* describe(Instability reason);

/// Failed steps in a row that make a simulation unstable.
inline constexpr int64_t kFailedStepsToUnstable = 10;
/// Steps in a row whose linear solve ended more than 100 times above its tolerance that make a
/// simulation unstable (a step just above it, Jacobi at its cap on a large model, does not).
inline constexpr int64_t kUnsolvedStepsToUnstable = 50;
/// Steps between two checks of the total energy while no tool acts.
inline constexpr int64_t kEnergyCheckSteps = 32;

/// Where a step's time went, microseconds (Box2D's b2Profile).
struct StepProfile {
  double forces_us = 0.0;     ///< spring, tetrahedron and volume passes (and linearisation)
  double integrate_us = 0.0;  ///< node pass or linear solve, update, finite check
  double recover_us = 0.0;    ///< rollback and redone steps (0 unless a step failed)
  double measure_us = 0.0;    ///< skin volume and the other measurements
};

/// What one step measured. Valid until the next step.
struct StepStats {
  double max_move_mm = 0.0;          ///< largest node move in this step
  double max_speed_mm_per_s = 0.0;   ///< largest node speed after the step (the rest test)
  double max_displacement_mm = 0.0;  ///< largest distance of a node from its rest position
  double skin_volume_mm3 = 0.0;      ///< volume enclosed by the deformed skin (layer 0)
  double volume_change_pct = 0.0;    ///< 100 (V - V_rest) / V_rest
  double kinetic_energy_j = 0.0;     ///< 1/2 sum m v^2, joules
  double step_us = 0.0;              ///< wall time of the step, microseconds
  StepProfile profile;
  int32_t cg_iterations = 0;  ///< implicit Euler only
  bool converged = false;     ///< max_speed_mm_per_s < SolverOptions::rest_speed_mm_per_s
  bool recovered = false;     ///< a non-finite state was rolled back and the step redone
  /// Not even backward Euler could take the step: the state was kept, the motion stopped, and
  /// the step does not count as converged (a load or dt far beyond what the model can take).
  bool failed = false;
  /// Implicit Euler: conjugate gradients reached their tolerance (true for other integrators).
  bool solver_converged = true;
  /// Implicit Euler: the final residual over the right-hand side, |b - A dv| / |b|.
  double solver_residual = 0.0;
  /// Implicit Euler: the fraction of the solved step taken, 1 (whole) unless the step would have
  /// collapsed a tetrahedron to under a fifth of its volume (then 1/2, 1/4, ...: a line search
  /// that keeps the tetrahedra from inverting under a load the linearisation cannot follow).
  double step_fraction = 1.0;
  /// Not kNone once the simulation has left physical bounds (Instability): stop, say so, and
  /// reset() before going on. Every entry point (lamina run, view, serve, Python, the C API)
  /// ends or stops on it.
  Instability unstable = Instability::kNone;
};

/// A simulation of a Model (not owned: it must outlive the simulation). Create with
/// make_simulation().
///
/// The state is what callers touch: positions x, velocities v, external forces f_ext (mN, set
/// before step()), and the clock. Write x and v of movable nodes between steps as you like; the
/// nodes that do not move (fixed, held, or outside local mode's set) change only through
/// fix_nodes(), hold_nodes(), release_nodes(), set_local_nodes() or reset(), which also refresh
/// what the measurements cache about them. Everything else (parameters as resolved, per-node
/// tables, force-term buffers, solver workspace) is private; read the parameters through the
/// accessors and change them with set_parameters().
///
/// A step costs in proportion to the movable nodes and their springs and tetrahedra, not to the
/// model: in local mode a poke on a 100k-node model steps only the nodes it reaches.
class Simulation {
 public:
  Simulation();
  ~Simulation();
  Simulation(const Simulation& other);
  Simulation(Simulation&& other) noexcept;
  Simulation& operator=(const Simulation& other);
  Simulation& operator=(Simulation&& other) noexcept;

  // State (#nodes by 3, column-major: x, y, z each contiguous).
  Eigen::MatrixX3d x;      ///< positions, mm
  Eigen::MatrixX3d v;      ///< velocities, mm/s
  Eigen::MatrixX3d f_ext;  ///< external (tool) forces, mN; set by the caller before step()
  double time_s = 0.0;
  int64_t steps = 0;
  int64_t recoveries = 0;  ///< steps that hit a non-finite state and were redone

  const Model& model() const;
  const Material& material() const;
  const SolverOptions& options() const;
  const std::vector<double>& mass_kg() const;   ///< per node, kg, as the material resolves it
  const std::vector<uint8_t>& fixed() const;    ///< per node: 1 = held where it is
  const std::vector<uint8_t>& movable() const;  ///< per node: 1 = integrated by step()
  /// Per spring, N/m, as the material resolves it (the paper's K, the model's, or identified
  /// from E and nu).
  const std::vector<double>& spring_stiffness_n_per_m() const;
  /// The tetrahedra's identified constants (empty unless Material::young_modulus_kpa > 0).
  const model::TetIdentification& tet_identification() const;

  /// The module's own access to what it keeps (an opaque type everywhere else).
  detail::Solver& solver() { return *solver_; }
  const detail::Solver& solver() const { return *solver_; }

 private:
  std::unique_ptr<detail::Solver> solver_;
};

/// Checks material and solver parameters (make_simulation() and set_parameters() call it).
/// \note Throws lamina::Error (kInvalidInput) naming the parameter and the value it got:
///   non-positive dt or rest speed, negative stiffness, damping, mass or anchor, non-finite
///   gravity, E with K, and so on.
void check_parameters(const Material& material, const SolverOptions& options);

/// Sets up a simulation of `model` at rest.
/// \note Throws lamina::Error (kInvalidInput) as check_parameters(), and for E on a model
///   without tetrahedra or projective dynamics with the tetrahedra's elasticity.
Simulation make_simulation(const Model& model, const Material& material = {},
                           const SolverOptions& options = {});

/// Changes material and solver parameters of a running simulation, keeping its state (positions,
/// velocities, time, fixed nodes, support). Switching to global mode makes every free node
/// movable; switching to local mode keeps only the currently movable ones (set_local_nodes()
/// adds more).
/// \note Throws lamina::Error (kInvalidInput) as make_simulation(); `sim` is then unchanged.
void set_parameters(Simulation& sim, const Material& material, const SolverOptions& options);

/// Holds these nodes at their rest positions from now on (a region of the skin attached to
/// surrounding anatomy). Without fixed nodes, support or anchors a pushed model drifts as a
/// rigid body and cannot return to rest.
/// \note Throws lamina::Error (kInvalidInput) for a node outside the model.
void fix_nodes(Simulation& sim, const std::vector<int32_t>& nodes);

/// Elastic support: ties each of these nodes to its rest position by a zero-length spring of the
/// given stiffness (N/m = mN/mm), as the tissue and organs around a liver hold it: a push dents
/// the organ where it is pushed instead of swinging it about a clamp. Replaces any earlier
/// support; an empty list removes it. model::surface_support() gives nodes and stiffness for a
/// surface held per unit area.
/// \note Throws lamina::Error (kInvalidInput) for a node outside the model, a count that differs
///   from the node count, or a stiffness that is negative or not finite.
void support_nodes(Simulation& sim, const std::vector<int32_t>& nodes,
                   const std::vector<double>& stiffness_n_per_m);

/// Each node's support stiffness, N/m, as support_nodes() left it (a cut divides a node's among
/// its copies: carry_over()); empty when nothing is supported.
std::vector<double> node_support(const Simulation& sim);

/// Holds these nodes at the given positions from now on (a displacement-controlled indenter, a
/// clamp that has moved them): like fix_nodes(), but at `positions` (one row per node, mm)
/// instead of their rest positions. Calling it again moves them on; called every step with nodes
/// that are all held already (an indenter, a grasper), it costs only the positions: what the
/// step visits and the prefactored solves stay (phantom, 22,267 nodes: 21 us a call against
/// 470 us when it set everything up again; sim_bench BM_HoldNodesEveryStep).
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
/// \note Throws lamina::Error (kInvalidInput) for a node outside the model, like fix_nodes().
void set_local_nodes(Simulation& sim, const std::vector<int32_t>& nodes);

/// Puts every node back at rest (x = X, v = 0, time 0), keeping parameters, fixed nodes and
/// support.
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

/// Builds now what the next step would otherwise build first (implicit Euler's multigrid
/// hierarchy, projective dynamics' factor), so that the first step is as fast as the ones after
/// it. Call it once the simulation is set up (fixed and supported nodes, parameters); step()
/// builds whatever is missing or out of date anyway. Returns the seconds it took.
double prepare_solver(Simulation& sim);

/// Whether implicit Euler's steps take the multigrid preconditioner: some node moves and
/// SolverOptions::preconditioner is kMultigrid, or kAuto and prepare_solver() (or the first
/// step) chose it.
bool uses_multigrid(const Simulation& sim);

/// Advances one time step, in named and timed stages (StepStats::profile): the force terms
/// (springs, tetrahedra, volume, support, gravity, tools), integration (semi-implicit Euler in
/// explicit_substeps() equal parts when dt is beyond its limit), the bounds check (a value that
/// is not finite, or a node farther from rest than the organ's size: roll back and redo the
/// step with two half steps, then with implicit Euler; if that fails too, keep the state, stop
/// the motion and report `failed`), the measurements, and the watch for instability
/// (StepStats::unstable: failed steps, energy growing while no tool acts, a stalled solver).
/// A tool acts when some movable node has an external force or a call since the last step
/// moved, held, released or re-parametrised nodes; writing x or v directly each step is a tool
/// the energy watch cannot see: drive nodes through f_ext or hold_nodes().
StepStats step(Simulation& sim);

/// True when no node moves faster than the rest speed (StepStats::converged): the single
/// definition of "at rest" every command uses.
inline bool at_rest(const StepStats& stats) {
  return stats.converged;
}

/// How long a model must stay at rest to count as settled, s (0.1 s: ten of the paper's steps).
inline constexpr double kQuietSeconds = 0.1;

/// Steps until at rest for `quiet_s` seconds of simulated time in a row, or options.max_steps.
/// One quiet step is not enough: a model just poked moves slowly in its first steps, and
/// velocities pass through zero at every turn of an oscillation.
/// @return the stats of the last step (converged is true only if the quiet window was reached)
StepStats run_to_convergence(Simulation& sim, double quiet_s = kQuietSeconds);

/// Steps in `quiet_s` seconds at sim's dt (at least 3: a velocity passes through zero at every
/// turn of an oscillation).
int64_t quiet_steps(const Simulation& sim, double quiet_s = kQuietSeconds);

/// The settling test every loop counts with: at rest (at_rest()) for `needed` steps in a row.
/// run_to_convergence(), interact::RestWatch (lamina run, run_tools) and the stability suite
/// share it.
struct RestStreak {
  int64_t needed = 3;  ///< quiet steps in a row that make a rest (quiet_steps())
  int64_t streak = 0;  ///< quiet steps so far

  /// Counts one step; a step that is not at rest starts the count again.
  /// @return true when the model has come to rest
  bool update(const StepStats& stats) {
    streak = at_rest(stats) ? streak + 1 : 0;
    return streak >= needed;
  }
};

/// Adds the spring forces at positions x (#nodes by 3, mm) to f (mN): the step's own two passes
/// (each spring once, then each node sums its springs) over every spring, with sim's workspace.
/// Forces sum to zero (Newton's third law).
void spring_forces(Simulation& sim, const Eigen::MatrixX3d& x, Eigen::MatrixX3d& f);

/// Adds every internal force at positions x to f (mN): springs, the tetrahedra's coupling and
/// volume, the volume term between layers, support and anchors (not damping, gravity or tools).
void internal_forces(Simulation& sim, const Eigen::MatrixX3d& x, Eigen::MatrixX3d& f);

/// The sum of the internal forces (internal_forces()) on the listed nodes, mN: what the tissue
/// pushes back with where it is loaded. Springs, support and anchors at the current positions;
/// the tetrahedra's as the last step computed them (at its start: one step old, which a haptic
/// loop reading it every few steps does not notice, and exact at rest).
Eigen::Vector3d internal_force_on(const Simulation& sim, const std::vector<int32_t>& nodes);

/// The implicit system's product y = (M + h gamma + h^2 K) p on the movable nodes (rows of other
/// nodes get 0), with K linearised by the last implicit step (one conjugate-gradient iteration's
/// main cost; public for benchmarks).
void implicit_system_product(Simulation& sim, double h, const Eigen::MatrixX3d& p,
                             Eigen::MatrixX3d& y);

/// Volume enclosed by layer `layer` of the model at positions x, mm^3.
double layer_volume(const Model& model, const Eigen::MatrixX3d& x, int32_t layer = 0);

/// omega_1, rad/s: the slowest natural frequency of the model about its rest shape, with its
/// held nodes, support and anchors and the current masses and stiffness (LOBPCG preconditioned
/// by a multigrid V-cycle on the stiffness at rest; the volume terms are left out), to within
/// about `tolerance` of itself (relative; the iteration's own rate estimates what is left).
/// Mass-proportional damping Material::mass_damping_per_s = 2 zeta omega_1 damps that mode at
/// damping ratio zeta: 1e-4 is far finer than a damping ratio is known.
/// \note Throws lamina::Error (kInvalidInput) if the model is held nowhere (its slowest motion
///   is a free drift) or everywhere.
double lowest_angular_frequency(const Simulation& sim, int32_t max_iterations = 300,
                                double tolerance = 1e-4);

/// Semi-implicit Euler's stability limit for this simulation's masses, stiffness and damping,
/// s: the largest dt with h^2 w^2 + 2 h c < 4 at every free node, w^2 Gershgorin's bound on the
/// node's row of M^-1 K (springs, tetrahedra, support and the volume term at rest) and c its
/// damping rate. A low estimate at rest (13x below the largest eigenvalue's on a liver), and
/// that slack is needed: compressed tetrahedra stiffen (docs/physics.md). step() splits a
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

/// Every stored energy at positions x, joules: springs, tetrahedra, support and anchors, and the
/// volume term.
double elastic_energy(const Simulation& sim, const Eigen::MatrixX3d& x);

/// Signed volumes of the model's tetrahedra at x, mm^3, and how many are inverted (volume <= 0).
int64_t inverted_tets(const Model& model, const Eigen::MatrixX3d& x);

}  // namespace lamina::sim
