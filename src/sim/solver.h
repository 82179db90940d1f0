#pragma once
// What a Simulation keeps besides the state callers touch (internal to module sim): the
// parameters as resolved, per-node tables, each force term's tables and per-step buffers, the
// lists of what a step visits, the caches of what stays put, and the integrators' workspace.
// Callers see only the opaque detail::Solver, as Box2D keeps its solver sets behind ids.
//
// Also the pieces every pass shares: fixed per-thread slices, per-thread partial sums, column
// pointers.

#include <immintrin.h>
#include <omp.h>

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "block_rows.h"
#include "lamina/model/identify_tets.h"
#include "lamina/sim/simulation.h"
#include "spring_lanes.h"

namespace lamina::sim::detail {

// Below this many springs a step runs on one thread: a parallel region costs a few microseconds,
// and on the paper-size model (10k springs) two threads gained only about 10%
// (docs/benchmarks.md). On a machine busy with other work, every one of a step's parallel
// regions (a dozen per implicit step with its CG iterations) can also wait for a time slice:
// a 13k-spring implicit run took 18x longer on two threads than on one beside a compiler.
constexpr int64_t kParallelSprings = 16384;
constexpr int kMaxThreads = 64;
constexpr size_t kMaxLayers = 16;  // BuildOptions::layers is at most 16

inline int threads_for_springs(int64_t springs) {
  return springs >= kParallelSprings ? std::clamp(omp_get_max_threads(), 1, kMaxThreads) : 1;
}

// Runs body(begin, end, thread) on `threads` threads, each over its own fixed slice of [0, n).
// Fixed slices and per-thread partial results summed in thread order keep every result the same
// from run to run (an OpenMP reduction may add the partials in any order).
template <class Body>
inline void for_slices(int64_t n, int threads, Body&& body) {
  if (threads <= 1) {
    body(int64_t{0}, n, 0);
    return;
  }
#pragma omp parallel num_threads(threads)
  {
    const int t = omp_get_thread_num(), T = omp_get_num_threads();
    body(n * t / T, n * (t + 1) / T, t);
  }
}

// Runs body(thread, threads) on each of `threads` threads in one parallel region (so that the
// body may hold a barrier), or body(0, 1) on the caller's alone.
template <class Body>
inline void on_threads(int threads, Body&& body) {
  if (threads <= 1) {
    body(0, 1);
    return;
  }
#pragma omp parallel num_threads(threads)
  body(omp_get_thread_num(), omp_get_num_threads());
}

// An entry of SpringTerm::adj_signed: e where the node is spring e's first end, ~e where its
// second. The spring, and the sign its stored force (on the first end) takes at this node.
inline int32_t spring_of(int32_t signed_spring) {
  return signed_spring < 0 ? ~signed_spring : signed_spring;
}
inline double end_sign(int32_t signed_spring) {
  return signed_spring < 0 ? -1.0 : 1.0;
}

// Per-thread partial results, one cache line each so that threads never share one.
struct alignas(64) Partial {
  double a = 0.0, b = 0.0, c = 0.0, d = 0.0;
  double volume6 = 0.0;  ///< the thread's share of 6 x the skin's volume (the lanes' pass)
  bool ok = true;
};
using Partials = std::array<Partial, kMaxThreads>;

// Column pointers of an #n by 3 column-major matrix.
struct Cols {
  double *x, *y, *z;
  explicit Cols(Eigen::MatrixX3d& m) : x(m.data()), y(x + m.rows()), z(y + m.rows()) {}
};
struct ConstCols {
  const double *x, *y, *z;
  explicit ConstCols(const Eigen::MatrixX3d& m) : x(m.data()), y(x + m.rows()), z(y + m.rows()) {}
};

/// The springs (spring_term.cpp): the paper's, and the tetrahedra's edges.
struct SpringTerm {
  std::vector<double> stiffness_n_per_m;  ///< per spring, as the material resolves it
  // Springs gathered per node (CSR), so each thread writes only its own nodes' forces.
  std::vector<int32_t> adj_offsets;  ///< #nodes + 1
  std::vector<int32_t> adj_other;    ///< the node at the other end
  std::vector<int32_t> adj_spring;   ///< the spring index
  std::vector<int32_t> adj_signed;   ///< e where the node is spring e's first end, ~e else
  Eigen::MatrixX3d force;            ///< per spring: its Hooke force on its first node, mN
  /// Per spring, for implicit Euler's stiffness matrix: unit direction and max(0, 1 - L/l), in
  /// single precision (it only steers the solve; docs/benchmarks.md has the measurement).
  Eigen::Matrix<float, Eigen::Dynamic, 4, Eigen::RowMajor> dir;
};

/// Local mode's active springs copied together (refresh()): a poke moves a hundred-odd nodes and
/// a thousand springs scattered over the model's arrays, and picking them out cost 3.3 ns a
/// spring and 17 ns a node (cache misses); copied together they stream from L1. Same kernel,
/// same order of sums: the same results to the bit.
struct CompactSprings {
  bool on = false;
  std::vector<int32_t> i, j;  ///< the springs' ends
  std::vector<double> rest_mm, k_n_per_m;
  Eigen::MatrixX3d force;  ///< per compact spring: its force on its first end, mN
  /// Per active node (active_nodes order) + 1, and its springs as compact indices (~ where the
  /// node is the second end), in the order of SpringTerm::adj_signed.
  std::vector<int32_t> offsets, signed_spring;
};

/// The tetrahedra are processed a SIMD register's worth of doubles at a time, one per lane:
/// each block keeps every field as an array over its lanes, so the passes' arithmetic runs
/// across tetrahedra with no shuffling (docs/architecture.md). Eight with AVX-512, four
/// otherwise: eight lanes on an AVX2 machine are two registers a value, and the passes' twenty-odd
/// live values then spill (AMD EPYC, AVX2: 4 lanes took the paper-size step from 2.2-2.5 to
/// 1.6 ms and the 5k one from 29-31 to 18-21 ms; docs/benchmarks.md).
#if defined(__AVX512F__)
constexpr int kTetLanes = 8;
#else
constexpr int kTetLanes = 4;
#endif

/// A block of kTetLanes tetrahedra's constants (unused lanes have zero stiffness).
struct alignas(64) TetBlock {
  double rest_length_mm[6][kTetLanes];  ///< edge rest lengths (edge order model::kTetEdge)
  double rest_volume_mm3[kTetLanes];
  double volume_stiffness[kTetLanes];  ///< k_v / V0, kPa / mm^3
  double guard_stiffness[kTetLanes];   ///< k_g / V0, kPa / mm^3 (the inversion guard)
  float q[21][kTetLanes];              ///< Q's upper triangle, N/m (TetIdentification::q_n_per_m)
  int32_t node[4][kTetLanes];
};

/// A block's linearisation at the step's start (implicit Euler's products).
struct alignas(64) TetBlockLinear {
  float w[18][kTetLanes];             ///< unit edge directions (corner kTetEdge[k][0] to [1])
  float geo[6][kTetLanes];            ///< each edge's geometric stiffness, max(0, tension) / length
  float grad[12][kTetLanes];          ///< dV/dx of each corner, mm^2
  float volume_stiffness[kTetLanes];  ///< d(pressure)/dV (the guard's included when it acts)
};

/// Twelve values per tetrahedron (a vector on its corners: force, product, diagonal), tetrahedron
/// by tetrahedron: corner c, axis d of tetrahedron t at [12 t + 3 c + d]. A block's pass writes
/// its eight rows together; a node gathers each of its corners from one cache line (a block's
/// lane-major layout would cost it three). Single precision: the node passes' gathers are the
/// step's largest memory traffic, and a force rounded to 1e-7 of itself is far below what the
/// solve resolves (its tolerance is 1e-3); zero at rest stays exactly zero.
using TetRows = std::vector<float>;

/// The tetrahedra's linearised stiffness assembled once a step into 3x3 blocks between nodes
/// (tet_assembly.cpp, assemble_tets in tet_term.cpp), for models whose element data outgrows
/// the caches: a product then streams each node's blocks (36 bytes a neighbour) instead of every
/// tetrahedron's constants, linearisation and rows (about 330 bytes a tetrahedron;
/// docs/benchmarks.md).
struct TetAssembly {
  bool on = false;       ///< set up (setup_tet_assembly; from 200,000 tetrahedra, tet_term.cpp)
  bool current = false;  ///< the blocks hold this step's linearisation (assemble_tets)
  std::vector<int32_t> offsets;  ///< per node + 1: its entries, its own block first
  std::vector<int32_t> column;   ///< per entry: the other node
  std::vector<int32_t> entry;    ///< per tetrahedron 16: the entry of corner pair (r, s), 4 r + s
  std::vector<float> block;      ///< per entry 9 (row-major), N/m; 3 more at the end (below)
  /// The product's argument, a node's x y z (and a 0) in one 32-byte row: a block's row times
  /// it is one vector multiply (assembled_tet_product_packed), and a neighbour is one load.
  std::vector<double> packed;
};

/// A block of kTetLanes tetrahedra's Neo-Hookean constants (neo_hookean_term.cpp; nodes in the
/// TetBlock of the same index). Unused lanes have zero rest volume: no force, no stiffness.
struct alignas(64) NeoBlock {
  /// The rest shape functions' gradients of corners 1-3 (rows of Dm^-1), 1/mm: F = sum_c x_c
  /// grad_c^T, grad_0 = -(grad_1 + grad_2 + grad_3).
  double grad[9][kTetLanes];
  double rest_volume_mm3[kTetLanes];
};

/// A Neo-Hookean block's linearisation at the step's start (implicit Euler's products).
struct alignas(64) NeoBlockLinear {
  float f[9][kTetLanes];       ///< F, row-major
  float cof[9][kTetLanes];     ///< dJ/dF, row-major
  float volume[kTetLanes];     ///< d(pressure)/dJ, kPa: lambda (+ the guard's modulus when it acts)
  float curvature[kTetLanes];  ///< the pressure on J's curvature, bounded to keep K positive
};

/// The tetrahedra (tet_term.cpp): each carries its share of its six edge springs, their
/// coupling, and resists a change of its signed volume (docs/physics.md). When on, the springs
/// (all tetrahedron edges) are carried here and the spring passes are skipped.
struct TetTerm {
  bool on = false;  ///< Material::young_modulus_kpa > 0 on a model with tetrahedra
  /// shared, never changed: copies of the simulation (a cut's carry_over()) read it
  std::shared_ptr<const model::TetIdentification> id;
  std::vector<TetBlock> block;         ///< tetrahedron t is lane t % 8 of block t / 8
  std::vector<TetBlockLinear> linear;  ///< per block (implicit Euler)
  TetRows force;                       ///< each corner's force, mN
  TetRows product;                     ///< each corner's share of (K p) (implicit Euler's CG)
  TetRows diag;                        ///< each corner's share of K's diagonal, N/m (Jacobi)
  // Each node's tetrahedron corners (CSR of t * 4 + c), for the node pass to gather.
  std::vector<int32_t> corner_offsets;  ///< #nodes + 1
  std::vector<int32_t> corners;
  TetAssembly assembly;
  /// Material::tet_model kNeoHookean: the blocks' energy is stable Neo-Hookean
  /// (neo_hookean_term.cpp) and `block` keeps only the nodes; force, product and diag rows,
  /// assembly and active lists are shared.
  bool neo_hookean = false;
  double mu_kpa = 0.0, lambda_kpa = 0.0, guard_kpa = 0.0;  ///< the energy's moduli
  std::vector<NeoBlock> neo;                               ///< per block
  std::vector<NeoBlockLinear> neo_linear;                  ///< per block (implicit Euler)
};

/// The volume term between layers (volume_term.cpp; Material::volume_stiffness_kpa).
struct VolumeTerm {
  // Each node's layer triangles as the two corners that follow it (CSR, 2 per triangle): the
  // gradient of its layer's volume is 1/6 sum x_b x x_c over them.
  std::vector<int32_t> corner_offsets;  ///< #nodes + 1
  std::vector<int32_t> corner_pairs;
  std::vector<double> pressure_jump_kpa;  ///< per layer: pressure inside minus outside it
  Eigen::MatrixX3d gradient;              ///< per movable node: d(its layer's volume)/dx, mm^2
};

/// What holds the organ besides fixed nodes (support_term.cpp): per node a zero-length spring
/// to its rest position, from Material::anchor_stiffness_n_per_m and support_nodes().
struct SupportTerm {
  std::vector<double> support_n_per_m;  ///< per node, from support_nodes() (0 elsewhere)
  /// per node, from set_contact_stiffness() (0 elsewhere): a world's contact and attachments
  std::vector<double> contact_n_per_m;
  std::vector<int32_t> contact_nodes;     ///< the nodes contact_n_per_m was last set on
  std::vector<double> stiffness_n_per_m;  ///< per node: anchor + support + contact
};

/// What step() remembers to tell an unstable simulation (stability_watch.cpp).
struct StabilityWatch {
  int64_t failed_streak = 0;    ///< failed steps in a row
  int64_t unsolved_streak = 0;  ///< steps in a row whose linear solve stalled (Measured)
  uint64_t setup_version = 0;   ///< Solver::setup_version when the energy watch began
  uint64_t held_moves = 0;      ///< Solver::held_moves when the energy watch began
  int64_t quiet_steps = 0;      ///< steps since a tool last acted
  bool armed = false;           ///< start_j holds the energy at the watch's first check
  double start_j = 0.0;
  Instability latched = Instability::kNone;
};

struct ProjectiveSolver;         // projective.cpp: the prefactored system, reused across steps
struct MultigridPreconditioner;  // preconditioner.h: the implicit step's hierarchy

struct Solver {
  const Model* model = nullptr;
  Material material;
  SolverOptions options;

  std::vector<double> mass_kg;
  std::vector<uint8_t> fixed;    ///< 1 = held (at its rest position, or where hold_nodes put it)
  std::vector<uint8_t> movable;  ///< 1 = integrated this step (not fixed, and local when kLocal)

  SpringTerm springs;
  CompactSprings compact;  ///< local mode's springs, copied together (explicit steps)
  SpringLanes lanes;       ///< the springs again, laid out for the explicit step (spring_lanes.h)
  TetTerm tets;
  VolumeTerm volume;
  SupportTerm support;

  double rest_skin_volume_mm3 = 0.0;
  std::vector<double> rest_layer_volume_mm3;  ///< per layer: the volume it encloses at rest
  /// A node this far from its rest position (twice the organ's own size, the diagonal of its
  /// box: the farthest a swing of the whole organ about a hold in it reaches) fails the step:
  /// no tissue stretches that far, and a blow-up passes it long before NaN.
  double blowup_limit_mm = 0.0;
  StabilityWatch watch;

  /// Counts changes of what a prefactored solve depends on (movable nodes, material, dt).
  uint64_t setup_version = 0;
  /// Counts moves of held nodes (hold_nodes): work done on the organ, which the energy watch
  /// must see as a tool acting, though no prefactored solve depends on it.
  uint64_t held_moves = 0;
  /// explicit_dt_limit(), cached for the setup_version it was computed at (0 = not yet).
  double explicit_limit_s = 0.0;
  uint64_t explicit_limit_version = 0;
  /// Counts changes of what the rest stiffness and the masses depend on (material, support),
  /// not of which nodes are held: explicit_dt_limit()'s per-node limits are cached for it.
  uint64_t stiffness_version = 1;
  mutable std::vector<double> row_limit_s;  // a cache: explicit_dt_limit() is const
  mutable uint64_t row_limit_version = 0;
  std::shared_ptr<ProjectiveSolver> projective;  ///< made on the first projective step
  /// made on the first implicit step that takes it (multigrid_applies())
  std::shared_ptr<MultigridPreconditioner> multigrid;

  // What a step visits: the movable nodes (ascending), every spring with a movable end, every
  // block of tetrahedra with a movable corner.
  std::vector<int32_t> active_nodes;
  std::vector<int32_t> active_springs;
  std::vector<int32_t> active_tets;  ///< blocks (TetTerm::block), not single tetrahedra
  // What the nodes that do not move add to the measurements, cached when the lists change.
  double frozen_max_displacement_mm = 0.0;
  /// Per layer: its triangles with a movable corner, and 6 x the signed volume of the others.
  std::vector<std::vector<int32_t>> layer_triangles;
  std::vector<std::vector<int32_t>> frozen_layer_triangles;  ///< per layer: the others
  std::vector<double> frozen_layer_volume6_mm3;
  /// The energy of the springs between two nodes that do not move (mN mm): the stability
  /// watch's total is the active springs' and this (EdgeSprings::part_energy_mj). Made when the
  /// watch next needs it after the nodes that do not move have changed (stale), not on every
  /// hold_nodes() of an indenter.
  double frozen_spring_energy_mj = 0.0;
  bool frozen_spring_energy_stale = true;

  // Workspace, sized once (no allocation per step). Rows of nodes that do not move stay zero in
  // r, z, p, dv: the implicit solve treats them as held.
  Eigen::MatrixX3d x_prev, v_prev;  ///< the movable nodes' state before the step (rollback)
  Eigen::MatrixX3d r, p, z, y, dv;  ///< implicit Euler: conjugate gradients; dv warm-starts
  Eigen::MatrixX3d diag;            ///< Jacobi preconditioner (per node, per axis)
};

/// Threads for a step: by the springs it visits (a block of tetrahedra counts as its six edges a
/// tetrahedron, whatever the block's width).
inline int threads_for(const Solver& s) {
  return threads_for_springs(static_cast<int64_t>(s.active_springs.size()) +
                             6 * kTetLanes * static_cast<int64_t>(s.active_tets.size()));
}

// Everything a step measures about the movable nodes, from their state before (x_prev) and after.
struct Measured {
  double move2 = 0.0, disp2 = 0.0, ke = 0.0, speed2 = 0.0;
  bool solved = true;     ///< implicit Euler: CG reached its tolerance
  bool stalled = false;   ///< implicit Euler: CG ended more than 100 times above its tolerance
  double residual = 0.0;  ///< implicit Euler: |r| / |b| at CG's end
  /// implicit Euler: the fraction of the solved step taken (volume_keeping_fraction), 1 whole
  double step_fraction = 1.0;
  /// 6 x the skin's volume over its triangles with a movable corner, when the pass measured it
  /// at the step's end (NaN: step() measures it).
  double skin_volume6 = std::numeric_limits<double>::quiet_NaN();
  bool ok = true;
};

inline Measured combine(const Partials& part, int threads) {
  Measured m;
  for (int t = 0; t < std::max(threads, 1); ++t) {
    m.move2 = std::max(m.move2, part[t].a);
    m.disp2 = std::max(m.disp2, part[t].b);
    m.ke += part[t].c;
    m.speed2 = std::max(m.speed2, part[t].d);
    m.ok = m.ok && part[t].ok;
  }
  return m;
}

// One node's end-of-step bookkeeping: the finite and bounded check (a blow-up can stay finite for
// a few steps while growing without bound) and the measurements.
inline void account(const Solver& s, const Eigen::MatrixX3d& X, int32_t i, double x0, double y0,
                    double z0, double nx, double ny, double nz, double vx, double vy, double vz,
                    Partial& out) {
  const double ex = nx - X(i, 0), ey = ny - X(i, 1), ez = nz - X(i, 2);
  const double lim = s.blowup_limit_mm;
  out.ok = out.ok && std::abs(ex) < lim && std::abs(ey) < lim && std::abs(ez) < lim &&
           std::isfinite(vx + vy + vz);  // NaN fails every comparison; inf - inf is NaN
  const double mx = nx - x0, my = ny - y0, mz = nz - z0;
  const double v2 = vx * vx + vy * vy + vz * vz;
  out.a = std::max(out.a, mx * mx + my * my + mz * mz);
  out.b = std::max(out.b, ex * ex + ey * ey + ez * ez);
  out.c += 0.5 * s.mass_kg[i] * v2;
  out.d = std::max(out.d, v2);
}

// The state a step writes, as column pointers.
struct NodeState {
  Cols x, v, xp, vp;
  NodeState(Simulation& sim, Solver& s) : x(sim.x), v(sim.v), xp(s.x_prev), vp(s.v_prev) {}
};

// A movable node's end of step: its old state saved for rollback (with save), the new velocity
// and the position it leads to stored, the node checked and measured.
inline void finish_node(const Solver& s, NodeState& st, int32_t i, double h, bool save, double vx,
                        double vy, double vz, Partial& acc) {
  const double x0 = st.x.x[i], y0 = st.x.y[i], z0 = st.x.z[i];
  if (save) {
    st.xp.x[i] = x0, st.xp.y[i] = y0, st.xp.z[i] = z0;
    st.vp.x[i] = st.v.x[i], st.vp.y[i] = st.v.y[i], st.vp.z[i] = st.v.z[i];
  }
  const double nx = x0 + h * vx, ny = y0 + h * vy, nz = z0 + h * vz;
  st.v.x[i] = vx, st.v.y[i] = vy, st.v.z[i] = vz;
  st.x.x[i] = nx, st.x.y[i] = ny, st.x.z[i] = nz;
  account(s, s.model->X, i, x0, y0, z0, nx, ny, nz, vx, vy, vz, acc);
}

// --- The springs (spring_term.cpp). ---
void setup_springs(Solver& s);
/// Each active spring's force at x into springs.force.
void spring_pass(Solver& s, const Eigen::MatrixX3d& x, int threads);
/// Each compact spring's force at x into compact.force (CompactSprings).
void compact_spring_pass(Solver& s, const Eigen::MatrixX3d& x, int threads);
/// The compact springs from the active ones when they are few (refresh()).
void refresh_compact_springs(Solver& s);
/// As spring_pass, plus implicit Euler's linearisation (springs.dir).
void spring_linearise(Solver& s, const Eigen::MatrixX3d& x, int threads);
/// The spring force on node i gathered from springs.force, added to f (below).
inline void gather_springs(const Solver& s, int32_t i, double& fx, double& fy, double& fz);
/// (K p)_i of the springs linearised by spring_linearise, and its Jacobi diagonal.
void spring_product(const Solver& s, int32_t i, const ConstCols& p, double& kx, double& ky,
                    double& kz);
void spring_diagonal(const Solver& s, int32_t i, double& d0, double& d1, double& d2);

// --- The tetrahedra (tet_term.cpp; their energies' passes: force_terms.h). ---
/// What an earlier identification knows of the model (a cut's carried simulation): the
/// identification kept alive, and model::KnownTets's tables (its `before` set to it).
struct KnownTets {
  std::shared_ptr<const model::TetIdentification> before;
  model::KnownTets tables;
};
/// make_simulation(), the tetrahedra `known` names (may be null) taking their constants from
/// an earlier identification (carry_over()).
Simulation make_simulation(const Model& model, const Material& material,
                           const SolverOptions& options, const KnownTets* known);
/// The tables every energy of the tetrahedra shares (identification, nodes, rows, corners), then
/// the energy's own constants (force_terms.h: TetEnergies); with `known`, the tetrahedra it
/// names take their constants from there.
void setup_tets(Solver& s, const KnownTets* known = nullptr);
/// Node i's corners of a per-tetrahedron buffer (tets.force, product or diag) added to f (below).
inline void gather_tets(const Solver& s, const TetRows& rows, int32_t i, double& fx, double& fy,
                        double& fz);
/// The active tetrahedra's 16 blocks of K each summed into tets.assembly (after tet_pass with
/// linearise); each thread adds to the rows of its range of nodes (tet_assembly.cpp).
void assemble_tets(Solver& s, int threads);
/// tets.assembly's pattern (the nodes joined by a tetrahedron) and each tetrahedron's entries.
void setup_tet_assembly(Solver& s);
/// The assembled (K p)_i of the tetrahedra, p packed by node, added to k (below).
inline void assembled_tet_product_packed(const TetAssembly& a, int32_t i, const double* packed,
                                         double* k);

// --- The volume term between layers (volume_term.cpp). ---
/// 6 x the signed volume of triangles [begin, end) of the list (of F when list is null).
double volume6_slice(const Eigen::MatrixX3i& F, const Eigen::MatrixX3d& x, const int32_t* list,
                     int64_t begin, int64_t end);
/// 6 x the signed volume of the listed triangles of F (all of F when list is null).
double volume6(const Eigen::MatrixX3i& F, const Eigen::MatrixX3d& x, const int32_t* list,
               int64_t count, int threads);
/// Volume enclosed by layer k at x, from the cached part of the nodes that do not move.
double layer_volume_now(const Solver& s, const Eigen::MatrixX3d& x, size_t k, int threads);
/// Sizes the volume term's tables (make_simulation).
void setup_volume_term(Solver& s);
/// At x: each layer's pressure jump and each movable node's volume gradient (start of a step).
void update_volume_term(Solver& s, const Eigen::MatrixX3d& x, int threads);
/// K_v / V0 of region r (between layers r and r + 1, or the core).
double region_stiffness(const Solver& s, size_t r);
/// The volume term's stiffness along p: (H p)_i = multiplier[layer of i] * gradient_i.
void volume_multipliers(const Solver& s, const Eigen::MatrixX3d& p, int threads,
                        double* multiplier);
/// The volume term's force on node i (from update_volume_term), added to f.
inline void add_volume_force(const Solver& s, int32_t i, double& fx, double& fy, double& fz) {
  const int32_t layer = s.model->layer_of[i];
  if (layer < 0) return;  // an interior node bounds no region
  const double jump = s.volume.pressure_jump_kpa[static_cast<size_t>(layer)];
  fx -= jump * s.volume.gradient(i, 0), fy -= jump * s.volume.gradient(i, 1),
      fz -= jump * s.volume.gradient(i, 2);
}

/// Node i's share of the implicit system's diagonal that is not stiffness, per unknown:
/// m (1 + h alpha) + h gamma, kg (the matrices built outside the hot loops: projective
/// dynamics' and the multigrid's).
inline double inertia_diagonal(const Solver& s, int32_t i, double h) {
  return s.mass_kg[i] * (1.0 + h * s.material.mass_damping_per_s) + h * s.material.damping_kg_per_s;
}

/// The stiffness at rest over rows row_of[node] (-1: left out), 3 per node interleaved: springs
/// or tetrahedra, support and anchors; not the volume term between layers (rest_stiffness.cpp).
void rest_stiffness_blocks(const Solver& s, const std::vector<int32_t>& row_of, int32_t rows,
                           BlockRows& out);
SparseRows rest_stiffness(const Solver& s, const std::vector<int32_t>& row_of, int32_t rows);

// --- Support: anchors and the elastic support (support_term.cpp). ---
void setup_support(Solver& s);

// --- Integrators (one file each). ---
/// y = (M + h gamma + h^2 K) p on the movable nodes, K as the last implicit step linearised it;
/// returns p . y (implicit_euler.cpp).
double system_product(Solver& s, double h, const Eigen::MatrixX3d& p, Eigen::MatrixX3d& y,
                      int threads);
/// What an integrator's stages took, microseconds (StepStats::profile).
Measured semi_implicit_euler(Simulation& sim, double h, bool save, StepProfile& profile);
/// Whether semi_implicit_euler() takes the lanes' fused pass (springs only, no volume term).
bool lanes_apply(const Solver& s);
Measured semi_implicit_euler_lanes(Simulation& sim, double h, bool save, StepProfile& profile);
/// The fraction (1, 1/2, 1/4, ... down to 1/1024) of the step x + h v1 that leaves every active
/// tetrahedron at least a fifth of its volume at x (inversion_limit.cpp); 1 for a step that
/// collapses none. Held nodes count as not moving.
double volume_keeping_fraction(const Solver& s, const Eigen::MatrixX3d& x,
                               const Eigen::MatrixX3d& v1, double h, int threads);
Measured implicit_euler(Simulation& sim, double h, bool save, int32_t& iterations,
                        StepProfile& profile);
Measured projective_step(Simulation& sim, double h, bool save, StepProfile& profile);
/// Factors projective dynamics' matrix unless it is current for the movable nodes and h.
void prepare_projective(Solver& s, double h);

/// Rebuilds what a step visits and what it caches about the nodes that stay put.
void refresh(Simulation& sim);
/// What refresh() caches of the positions of nodes that do not move, after hold_nodes() moved
/// them: the largest displacement among them and their layers' volume share. The lists stay.
void refresh_frozen_positions(Simulation& sim);
/// Counts the step into the watch and sets st.unstable (stability_watch.cpp).
/// `stalled`: the step's linear solve ended far above its tolerance (Measured::stalled).
void watch_stability(Simulation& sim, StepStats& st, bool stalled);

// The spring force on a node from a per-spring force buffer (each spring's force on its first
// end): its springs' forces [a, end) of signed_spring, + where it is the first end, - where the
// second. signed_spring holds e for the first and ~e (negative) for the second, so one load gives
// both. Two sets of sums halve the chain of dependent additions (a node has about ten springs).
inline void gather_signed(const int32_t* __restrict signed_spring, int32_t a, int32_t end,
                          const Eigen::MatrixX3d& force, double& fx, double& fy, double& fz) {
  const double* __restrict gx = force.data();
  const double* __restrict gy = gx + force.rows();
  const double* __restrict gz = gy + force.rows();
  double ax = 0.0, ay = 0.0, az = 0.0, bx = 0.0, by = 0.0, bz = 0.0;
  for (; a + 1 < end; a += 2) {
    const int32_t c0 = signed_spring[a], c1 = signed_spring[a + 1];
    const int32_t e0 = spring_of(c0), e1 = spring_of(c1);
    const double s0 = end_sign(c0), s1 = end_sign(c1);
    ax += s0 * gx[e0], ay += s0 * gy[e0], az += s0 * gz[e0];
    bx += s1 * gx[e1], by += s1 * gy[e1], bz += s1 * gz[e1];
  }
  if (a < end) {
    const int32_t c = signed_spring[a], e = spring_of(c);
    const double sg = end_sign(c);
    ax += sg * gx[e], ay += sg * gy[e], az += sg * gz[e];
  }
  fx += ax + bx, fy += ay + by, fz += az + bz;
}

// The spring force on node i from the spring pass (springs.force).
inline void gather_springs(const Solver& s, int32_t i, double& fx, double& fy, double& fz) {
  const SpringTerm& t = s.springs;
  gather_signed(t.adj_signed.data(), t.adj_offsets[i], t.adj_offsets[i + 1], t.force, fx, fy, fz);
}

inline void gather_tets(const Solver& s, const TetRows& rows, int32_t i, double& fx, double& fy,
                        double& fz) {
  const TetTerm& t = s.tets;
  const float* __restrict data = rows.data();
  double ax = 0.0, ay = 0.0, az = 0.0;
  for (int32_t a = t.corner_offsets[i]; a < t.corner_offsets[i + 1]; ++a) {
    const float* f = data + 3 * static_cast<int64_t>(t.corners[a]);  // 12 t + 3 c
    ax += f[0], ay += f[1], az += f[2];
  }
  fx += ax, fy += ay, fz += az;
}

/// (K p)_i from the assembled blocks and p packed by node (TetAssembly::packed), added to k:
/// each block row (3 floats, and the next one, which meets p's 0) times p_j, in 4-wide double
/// vectors with one accumulator per row. Six loads a neighbour where the scalar product over
/// p's three columns took thirteen (docs/benchmarks.md, issue 48).
inline void assembled_tet_product_packed(const TetAssembly& a, int32_t i, const double* packed,
                                         double* k) {
  typedef double D4 __attribute__((vector_size(32)));
  const float* __restrict blocks = a.block.data();
  const int32_t* __restrict column = a.column.data();
  // Four floats widened by one vcvtps2pd (GCC 12 lowers __builtin_convertvector of four floats
  // to four doubles through the stack).
  const auto widen = [](const float* f) {
#if defined(__AVX__)
    return D4(_mm256_cvtps_pd(_mm_loadu_ps(f)));
#else
    return D4{f[0], f[1], f[2], f[3]};
#endif
  };
  // Two neighbours a round, each into its own three sums: a sum's add waits for the one before.
  D4 r[2][3] = {};
  const auto add = [&](int32_t e, D4* acc) {
    D4 pj;
    __builtin_memcpy(&pj, packed + 4 * static_cast<int64_t>(column[e]), sizeof pj);
    const float* b = blocks + 9 * static_cast<int64_t>(e);
    acc[0] += widen(b) * pj;
    acc[1] += widen(b + 3) * pj;
    acc[2] += widen(b + 6) * pj;  // reads one float past the last block: padded
  };
  int32_t e = a.offsets[i];
  const int32_t end = a.offsets[i + 1];
  for (; e + 1 < end; e += 2) add(e, r[0]), add(e + 1, r[1]);
  if (e < end) add(e, r[0]);
  for (int c = 0; c < 3; ++c) {
    const D4 sum = r[0][c] + r[1][c];
    k[c] += sum[0] + sum[1] + sum[2];
  }
}

// The force on movable node i (mN) but its springs' and tetrahedra's: the tool's, gravity, its
// support and anchor, the volume term's pressure (from update_volume_term) and, if damped,
// -(gamma + alpha m) v. Backward Euler puts the damping into its matrix instead.
inline void node_force_but_elements(const Solver& s, const Simulation& sim, int32_t i, bool damped,
                                    double& fx, double& fy, double& fz) {
  const Material& mat = s.material;
  const Eigen::MatrixX3d& X = s.model->X;
  const double m = s.mass_kg[i], k = s.support.stiffness_n_per_m[i];
  const Eigen::Vector3d& g = mat.gravity_mm_per_s2;
  fx = sim.f_ext(i, 0) + m * g.x() - k * (sim.x(i, 0) - X(i, 0));
  fy = sim.f_ext(i, 1) + m * g.y() - k * (sim.x(i, 1) - X(i, 1));
  fz = sim.f_ext(i, 2) + m * g.z() - k * (sim.x(i, 2) - X(i, 2));
  if (damped) {
    const double damp = mat.damping_kg_per_s + mat.mass_damping_per_s * m;
    fx -= damp * sim.v(i, 0), fy -= damp * sim.v(i, 1), fz -= damp * sim.v(i, 2);
  }
  if (mat.volume_stiffness_kpa > 0.0) add_volume_force(s, i, fx, fy, fz);
}

// The force on movable node i (mN): node_force_but_elements() and its springs' and tetrahedra's
// (gathered from their passes).
inline void node_force(const Solver& s, const Simulation& sim, int32_t i, bool damped, double& fx,
                       double& fy, double& fz) {
  node_force_but_elements(s, sim, i, damped, fx, fy, fz);
  if (s.tets.on)
    gather_tets(s, s.tets.force, i, fx, fy, fz);  // the springs are the tetrahedra's edges
  else
    gather_springs(s, i, fx, fy, fz);
}

// The spring force on the q-th active node from the compact springs' pass (CompactSprings), in
// gather_springs()'s order.
inline void gather_compact_springs(const Solver& s, int64_t q, double& fx, double& fy, double& fz) {
  const CompactSprings& c = s.compact;
  gather_signed(c.signed_spring.data(), c.offsets[q], c.offsets[q + 1], c.force, fx, fy, fz);
}

}  // namespace lamina::sim::detail
