#pragma once
// The pieces every integrator's passes share (internal to module sim): fixed per-thread slices,
// per-thread partial sums, column pointers, and a node's end of step (rollback copy, update,
// finite check, measurements).

#include <omp.h>

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

#include "lamina/sim/simulation.h"

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

/// Threads for a step of `s`: by the springs it visits.
inline int threads_for(const Simulation& s) {
  return threads_for_springs(static_cast<int64_t>(s.active_springs.size()));
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

// An entry of Simulation::adj_signed: e where the node is spring e's first end, ~e where its
// second. The spring, and the sign its stored force (on the first end) takes at this node.
inline int32_t spring_of(int32_t signed_spring) {
  return signed_spring < 0 ? ~signed_spring : signed_spring;
}
inline double end_sign(int32_t signed_spring) { return signed_spring < 0 ? -1.0 : 1.0; }

// Per-thread partial results, one cache line each so that threads never share one.
struct alignas(64) Partial {
  double a = 0.0, b = 0.0, c = 0.0;
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
  explicit ConstCols(const Eigen::MatrixX3d& m)
      : x(m.data()), y(x + m.rows()), z(y + m.rows()) {}
};

// Everything a step measures about the movable nodes, from their state before (x_prev) and after.
struct Measured {
  double move2 = 0.0, disp2 = 0.0, ke = 0.0;
  bool ok = true;
};

inline Measured combine(const Partials& part, int threads) {
  Measured m;
  for (int t = 0; t < std::max(threads, 1); ++t) {
    m.move2 = std::max(m.move2, part[t].a);
    m.disp2 = std::max(m.disp2, part[t].b);
    m.ke += part[t].c;
    m.ok = m.ok && part[t].ok;
  }
  return m;
}

// One node's end-of-step bookkeeping: the finite and bounded check (a blow-up can stay finite for
// a few steps while growing without bound) and the measurements.
inline void account(const Simulation& s, int32_t i, double x0, double y0, double z0, double nx,
                    double ny, double nz, double vx, double vy, double vz, Partial& out) {
  const Eigen::MatrixX3d& X = s.model->X;
  const double ex = nx - X(i, 0), ey = ny - X(i, 1), ez = nz - X(i, 2);
  const double lim = s.blowup_limit_mm;
  out.ok = out.ok && std::abs(ex) < lim && std::abs(ey) < lim && std::abs(ez) < lim &&
           std::isfinite(vx + vy + vz);  // NaN fails every comparison; inf - inf is NaN
  const double mx = nx - x0, my = ny - y0, mz = nz - z0;
  out.a = std::max(out.a, mx * mx + my * my + mz * mz);
  out.b = std::max(out.b, ex * ex + ey * ey + ez * ez);
  out.c += 0.5 * s.mass_kg[i] * (vx * vx + vy * vy + vz * vz);
}

// The state a step writes, as column pointers.
struct NodeState {
  Cols x, v, xp, vp;
  explicit NodeState(Simulation& s) : x(s.x), v(s.v), xp(s.x_prev), vp(s.v_prev) {}
};

// A movable node's end of step: its old state saved for rollback (with save), the new velocity
// and the position it leads to stored, the node checked and measured.
inline void finish_node(const Simulation& s, NodeState& st, int32_t i, double h, bool save,
                        double vx, double vy, double vz, Partial& acc) {
  const double x0 = st.x.x[i], y0 = st.x.y[i], z0 = st.x.z[i];
  if (save) {
    st.xp.x[i] = x0, st.xp.y[i] = y0, st.xp.z[i] = z0;
    st.vp.x[i] = st.v.x[i], st.vp.y[i] = st.v.y[i], st.vp.z[i] = st.v.z[i];
  }
  const double nx = x0 + h * vx, ny = y0 + h * vy, nz = z0 + h * vz;
  st.v.x[i] = vx, st.v.y[i] = vy, st.v.z[i] = vz;
  st.x.x[i] = nx, st.x.y[i] = ny, st.x.z[i] = nz;
  account(s, i, x0, y0, z0, nx, ny, nz, vx, vy, vz, acc);
}

// The volume term (volume_term.cpp; Material::volume_stiffness_kpa).
/// 6 x the signed volume of the listed triangles of F (all of F when list is null).
double volume6(const Eigen::MatrixX3i& F, const Eigen::MatrixX3d& x, const int32_t* list,
               int64_t count, int threads);
/// Volume enclosed by layer k at x, from the cached part of the nodes that do not move.
double layer_volume_now(const Simulation& s, const Eigen::MatrixX3d& x, size_t k, int threads);
/// Sizes the volume term's tables (make_simulation).
void setup_volume_term(Simulation& s);
/// At x: each layer's pressure jump and each movable node's volume gradient (start of a step).
void update_volume_term(Simulation& s, const Eigen::MatrixX3d& x, int threads);
/// K_v / V0 of region r (between layers r and r + 1, or the core).
double region_stiffness(const Simulation& s, size_t r);
/// The volume term's stiffness along p: (H p)_i = multiplier[layer of i] * gradient_i, H the
/// sum over regions of K_v / V0 G G^T (G the gradient of the region's volume).
void volume_multipliers(const Simulation& s, const Eigen::MatrixX3d& p, int threads,
                        double* multiplier);
/// Adds to each node's Gershgorin row sum (N/m) the volume term's: sum over the regions it
/// bounds of K_v / V0 |g_i|_max ||G_r||_1, gradients at rest (explicit_dt_limit()).
void add_volume_stiffness_rows(const Simulation& s, std::vector<double>& row);
/// The volume term's energy at x, 1e-6 J (kPa mm^3).
double volume_energy(const Simulation& s, const Eigen::MatrixX3d& x);

/// Projective dynamics ("fast mass-spring", Liu et al. 2013) for Integrator::kProjective
/// (projective.cpp).
Measured projective_step(Simulation& s, double h, bool save);

}  // namespace lamina::sim::detail
