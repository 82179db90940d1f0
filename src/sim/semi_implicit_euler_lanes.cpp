// Semi-implicit Euler on the paper's network (springs only, no volume term, no tetrahedra): one
// parallel region per step with two phases. First each thread packs its share of the positions
// the pass reads (spring_lanes.h); then each thread takes its share of the blocks of nodes, and
// for each block computes the springs' forces in SIMD lanes and integrates, checks and measures
// the block's movable nodes in double, the node's state read and written once.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <limits>

#include "solver.h"
#include "spring_lanes_kernel.h"

namespace lamina::sim::detail {
namespace {

void pack_positions(SpringLanes& t, const Eigen::MatrixX3d& x, int64_t begin, int64_t end) {
  const ConstCols c(x);
  if (t.reads_all) {
    for (int64_t i = begin; i < end; ++i)
      pack_position(t, static_cast<int32_t>(i), c.x[i], c.y[i], c.z[i]);
    return;
  }
  for (int64_t q = begin; q < end; ++q) {
    const int32_t i = t.read_nodes[q];
    pack_position(t, i, c.x[i], c.y[i], c.z[i]);
  }
}

using DoubleLanes = xsimd::batch<double>;
constexpr int32_t kHalf = static_cast<int32_t>(DoubleLanes::size);  // doubles per register
static_assert(kLanes % kHalf == 0, "a block of float lanes is whole registers of doubles");

// A thread's running measurements, lane by lane (reduced once, at the end of its blocks). Set
// with DoubleLanes(0.0), not {0.0}: braces pick xsimd's initializer-list constructor, which
// fills the first lane only (a resumed run's kinetic energy caught it).
struct LaneMeasures {
  DoubleLanes move2 = DoubleLanes(0.0), disp2 = DoubleLanes(0.0), ke = DoubleLanes(0.0),
              speed2 = DoubleLanes(0.0);
  bool ok = true;
};

// What every lane needs beside its node's own state.
struct NodeConstants {
  const Solver& s;
  ConstCols X, fe;
  double h, gamma, alpha, lim, gx, gy, gz;
};

// Nodes [i, i + kHalf), all inside the model: their spring forces f (from the lanes), the rest of
// node_force(), the semi-implicit Euler update, the rollback copy (with save), the check and the
// measurements, in double lanes. A node that does not move keeps its state (and is not measured).
void integrate_lanes(const NodeConstants& c, NodeState& st, int32_t i, const float* fx,
                     const float* fy, const float* fz, bool save, LaneMeasures& acc) {
  using D = DoubleLanes;
  const auto movable = D::load_unaligned(c.s.lanes.movable.data() + i) != D(0.0);
  const D m = D::load_unaligned(c.s.mass_kg.data() + i);
  const D ks = D::load_unaligned(c.s.support.stiffness_n_per_m.data() + i);
  const D damp = xsimd::fma(D(c.alpha), m, D(c.gamma)), h_m = D(c.h) / m;
  const D x = D::load_unaligned(st.x.x + i), y = D::load_unaligned(st.x.y + i),
          z = D::load_unaligned(st.x.z + i);
  const D vx = D::load_unaligned(st.v.x + i), vy = D::load_unaligned(st.v.y + i),
          vz = D::load_unaligned(st.v.z + i);
  const D ex = x - D::load_unaligned(c.X.x + i), ey = y - D::load_unaligned(c.X.y + i),
          ez = z - D::load_unaligned(c.X.z + i);
  alignas(64) double f64[3][kHalf];
  for (int32_t q = 0; q < kHalf; ++q) f64[0][q] = fx[q], f64[1][q] = fy[q], f64[2][q] = fz[q];
  const D ux =
      D::load_unaligned(c.fe.x + i) + m * D(c.gx) - ks * ex - damp * vx + D::load_aligned(f64[0]);
  const D uy =
      D::load_unaligned(c.fe.y + i) + m * D(c.gy) - ks * ey - damp * vy + D::load_aligned(f64[1]);
  const D uz =
      D::load_unaligned(c.fe.z + i) + m * D(c.gz) - ks * ez - damp * vz + D::load_aligned(f64[2]);
  if (save) {
    x.store_unaligned(st.xp.x + i), y.store_unaligned(st.xp.y + i), z.store_unaligned(st.xp.z + i);
    vx.store_unaligned(st.vp.x + i), vy.store_unaligned(st.vp.y + i),
        vz.store_unaligned(st.vp.z + i);
  }
  const D nvx = xsimd::select(movable, vx + h_m * ux, vx),
          nvy = xsimd::select(movable, vy + h_m * uy, vy),
          nvz = xsimd::select(movable, vz + h_m * uz, vz);
  const D mx = xsimd::select(movable, D(c.h) * nvx, D(0.0)),
          my = xsimd::select(movable, D(c.h) * nvy, D(0.0)),
          mz = xsimd::select(movable, D(c.h) * nvz, D(0.0));
  nvx.store_unaligned(st.v.x + i), nvy.store_unaligned(st.v.y + i), nvz.store_unaligned(st.v.z + i);
  (x + mx).store_unaligned(st.x.x + i), (y + my).store_unaligned(st.x.y + i),
      (z + mz).store_unaligned(st.x.z + i);
  // account(), lane by lane: the moved node's distance from rest, the move, the energy.
  const D nex = ex + mx, ney = ey + my, nez = ez + mz, lim(c.lim);
  const auto bounded = xsimd::abs(nex) < lim && xsimd::abs(ney) < lim && xsimd::abs(nez) < lim;
  const D vsum = nvx + nvy + nvz;
  acc.ok = acc.ok &&
           xsimd::all(!movable || (bounded && vsum == vsum &&
                                   xsimd::abs(vsum) < D(std::numeric_limits<double>::infinity())));
  const D zero(0.0), v2 = nvx * nvx + nvy * nvy + nvz * nvz;
  acc.move2 = xsimd::max(acc.move2, xsimd::select(movable, mx * mx + my * my + mz * mz, zero));
  acc.disp2 =
      xsimd::max(acc.disp2, xsimd::select(movable, nex * nex + ney * ney + nez * nez, zero));
  acc.ke = acc.ke + xsimd::select(movable, D(0.5) * m * v2, zero);
  acc.speed2 = xsimd::max(acc.speed2, xsimd::select(movable, v2, zero));
}

// Movable node i alone, its spring force lane q of f: the rest of node_force(), the update, the
// rollback copy, the check and the measurements (finish_node()). Inlined by force: as a call,
// the paper's poke to rest took 5.55 ms instead of 4.77 (122 nodes a step, 1,573 steps).
[[gnu::always_inline]] inline void integrate_node(Simulation& sim, NodeState& st, int32_t i,
                                                  double h, bool save, const float* fx,
                                                  const float* fy, const float* fz, int32_t q,
                                                  Partial& acc) {
  const Solver& s = sim.solver();
  double ux, uy, uz;
  node_force_but_elements(s, sim, i, /*damped=*/true, ux, uy, uz);
  ux += fx[q], uy += fy[q], uz += fz[q];
  const double h_m = h / s.mass_kg[i];
  finish_node(s, st, i, h, save, st.v.x[i] + h_m * ux, st.v.y[i] + h_m * uy, st.v.z[i] + h_m * uz,
              acc);
}

// Blocks [begin, end) of active_blocks: forces, integration, the rollback copy, measurements.
Partial integrate_blocks(Simulation& sim, double h, bool save, int64_t begin, int64_t end) {
  Solver& s = sim.solver();
  const SpringLanes& t = s.lanes;
  const Material& mat = s.material;
  const Eigen::Vector3d& g = mat.gravity_mm_per_s2;
  const NodeConstants c{s,
                        ConstCols(s.model->X),
                        ConstCols(sim.f_ext),
                        h,
                        mat.damping_kg_per_s,
                        mat.mass_damping_per_s,
                        s.blowup_limit_mm,
                        g.x(),
                        g.y(),
                        g.z()};
  NodeState st(sim, s);
  Partial acc;
  LaneMeasures lanes;
  alignas(64) float fx[kLanes], fy[kLanes], fz[kLanes];
  for (int64_t k = begin; k < end; ++k) {
    const int32_t b = t.active_blocks[k];
    block_spring_force(t, b, fx, fy, fz);
    const int32_t first = b * kLanes, last = std::min(t.nodes, first + kLanes);
    int32_t i = first;
    for (; i + kHalf <= last; i += kHalf)
      integrate_lanes(c, st, i, fx + (i - first), fy + (i - first), fz + (i - first), save, lanes);
    for (; i < last; ++i)  // the model's last few nodes, one at a time
      if (s.movable[i]) integrate_node(sim, st, i, h, save, fx, fy, fz, i - first, acc);
  }
  alignas(64) double move2[kHalf], disp2[kHalf], ke[kHalf], speed2[kHalf];
  lanes.move2.store_aligned(move2), lanes.disp2.store_aligned(disp2);
  lanes.ke.store_aligned(ke), lanes.speed2.store_aligned(speed2);
  for (int32_t q = 0; q < kHalf; ++q) {
    acc.a = std::max(acc.a, move2[q]), acc.b = std::max(acc.b, disp2[q]);
    acc.c += ke[q], acc.d = std::max(acc.d, speed2[q]);
  }
  acc.ok = acc.ok && lanes.ok;
  return acc;
}

}  // namespace

bool lanes_apply(const Solver& s) {
  // Local mode's few hundred movable nodes can be scattered over many blocks: below half the
  // lanes in use, the per-spring passes (which visit only what moves) are faster.
  // Then local mode's own blocks (LocalLanes), when there are few enough for one thread.
  const auto lanes_used = static_cast<size_t>(kLanes) * s.lanes.active_blocks.size();
  return !s.tets.on && !(s.material.volume_stiffness_kpa > 0.0) &&
         (2 * s.active_nodes.size() >= lanes_used || s.lanes.local.on);
}

// Threads for the pass: from 8,192 lane entries (the paper-size network's 25,600 take 23 us on
// one thread, 15 on two; docs/benchmarks.md). One parallel region a step, so a busy machine
// costs it one wait for a time slice, not a dozen as in an implicit step.
int lanes_threads(const SpringLanes& t) {
  return t.work_before.back() * kLanes >= 8192 ? std::clamp(omp_get_max_threads(), 1, kMaxThreads)
                                               : 1;
}

// Thread k of n's share of 6 x the skin's volume at the step's end, over its triangles with a
// movable corner (the rest is cached: Solver::frozen_layer_volume6_mm3).
double skin_volume6_share(const Solver& s, const Eigen::MatrixX3d& x, int k, int n) {
  const Eigen::MatrixX3i& F = s.model->layers[0].F;
  const std::vector<int32_t>& tris = s.layer_triangles[0];
  const auto count = static_cast<int64_t>(tris.size());
  return volume6_slice(F, x, count == F.rows() ? nullptr : tris.data(), count * k / n,
                       count * (k + 1) / n);
}

namespace {

// Local mode's own blocks (LocalLanes), on one thread: the positions they read packed, then each
// block's spring forces in lanes and its nodes integrated one at a time (their state is not
// contiguous), as integrate_blocks() does for the last few nodes of the model.
Measured local_lanes_step(Simulation& sim, double h, bool save) {
  Solver& s = sim.solver();
  SpringLanes& t = s.lanes;
  const LocalLanes& l = t.local;
  const ConstCols c(sim.x);
  for (int32_t i : l.read_nodes) pack_position(t, i, c.x[i], c.y[i], c.z[i]);
  NodeState st(sim, s);
  Partial acc;
  alignas(64) float fx[kLanes], fy[kLanes], fz[kLanes];
  for (int32_t b = 0, blocks = block_count(l.count); b < blocks; ++b) {
    local_block_spring_force(t, b, fx, fy, fz);
    for (int32_t q = 0; q < kLanes && b * kLanes + q < l.count; ++q)
      integrate_node(sim, st, s.active_nodes[b * kLanes + q], h, save, fx, fy, fz, q, acc);
  }
  if (!s.layer_triangles.empty()) acc.volume6 = skin_volume6_share(s, sim.x, 0, 1);
  Measured m = combine(Partials{acc}, 1);
  if (!s.layer_triangles.empty()) m.skin_volume6 = acc.volume6;
  return m;
}

}  // namespace

Measured semi_implicit_euler_lanes(Simulation& sim, double h, bool save, StepProfile& profile) {
  Solver& s = sim.solver();
  SpringLanes& t = s.lanes;
  if (t.local.on) {
    const auto t0 = std::chrono::steady_clock::now();
    const Measured m = local_lanes_step(sim, h, save);
    profile.integrate_us +=
        std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
    return m;
  }
  const int T = lanes_threads(t);
  const auto t0 = std::chrono::steady_clock::now();
  const int64_t reads = t.reads_all ? t.nodes : static_cast<int64_t>(t.read_nodes.size());
  const auto blocks = static_cast<int64_t>(t.active_blocks.size());
  const bool volume = !s.layer_triangles.empty();
  Partials part;
  if (T <= 1) {
    pack_positions(t, sim.x, 0, reads);
    part[0] = integrate_blocks(sim, h, save, 0, blocks);
    if (volume) part[0].volume6 = skin_volume6_share(s, sim.x, 0, 1);
  } else {
    // One parallel region: pack, integrate the blocks, measure the skin's volume.
#pragma omp parallel num_threads(T)
    {
      const int k = omp_get_thread_num(), n = omp_get_num_threads();
      const int64_t begin = first_block(t, k, n), end = first_block(t, k + 1, n);
      // Each thread packs the nodes it integrates (in global mode), so that the positions its
      // gathers read were written by its own core but for the blocks' borders.
      if (t.reads_all)
        pack_positions(t, sim.x, k == 0 ? 0 : kLanes * int64_t{t.active_blocks[begin]},
                       end == blocks ? reads : kLanes * int64_t{t.active_blocks[end]});
      else
        pack_positions(t, sim.x, reads * k / n, reads * (k + 1) / n);
#pragma omp barrier
      part[k] = integrate_blocks(sim, h, save, begin, end);
      if (volume) {
#pragma omp barrier
        part[k].volume6 = skin_volume6_share(s, sim.x, k, n);
      }
    }
  }
  // One fused pass: its time is the integration's (forces_us stays for the other paths).
  profile.integrate_us +=
      std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
  Measured m = combine(part, T);
  if (volume) {
    m.skin_volume6 = 0.0;
    for (int k = 0; k < std::max(T, 1); ++k) m.skin_volume6 += part[k].volume6;
  }
  return m;
}

}  // namespace lamina::sim::detail
