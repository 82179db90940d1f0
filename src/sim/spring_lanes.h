#pragma once
// The explicit step's spring forces, one SIMD lane per node (xsimd; docs/benchmarks.md, "The hot
// loop"). Nodes go in blocks of kLanes consecutive indices; block b holds, slot after slot, each
// of its nodes' springs as "the node at the other end, rest length, stiffness" (a node with fewer
// springs than the block's most connected one is padded with springs to itself of zero
// stiffness). A block's force is then a run of identical vector steps with no scatter, no
// per-spring buffer and no race: a node's lane sums its own springs (each spring is evaluated
// once from each end, which the gathers' saving pays for).
//
// The pass reads positions from a single-precision copy, x - centre packed four floats per node
// (one cache line per neighbour for the gathers), made at the step's start from the
// double-precision state; the integration stays in double. A spring's force is k L (1/L - 1/l) d;
// where its rest length is its edge's length at rest, 1/L is computed from the same floats by
// the same operations as 1/l, so that a network at rest feels exactly zero force.

#include <algorithm>
#include <cstdint>
#include <vector>
#include <xsimd/memory/xsimd_aligned_allocator.hpp>

namespace lamina::sim::detail {

// Lanes per SIMD register of floats on the CPU compiled for (spring_lanes_kernel.h checks it
// against xsimd's): AVX-512 16, AVX 8, else 4.
#if defined(__AVX512F__)
constexpr int32_t kLanes = 16;
#elif defined(__AVX__)
constexpr int32_t kLanes = 8;
#else
constexpr int32_t kLanes = 4;
#endif
template <class T>
using AlignedVector = std::vector<T, xsimd::aligned_allocator<T>>;

struct Solver;

/// Local mode's few movable nodes as blocks of their own, for when the model's blocks they lie
/// in would be less than half used (the paper's poke: 122 nodes over 27 blocks of 16): block b
/// holds active_nodes[kLanes b, kLanes (b + 1)), the last padded with the last node at zero
/// stiffness, each lane's slots copied from the model's layout (refresh_spring_lanes()).
struct LocalLanes {
  bool on = false;
  int32_t count = 0;                  ///< the movable nodes
  AlignedVector<int32_t> own4;        ///< per lane: 4 x its node
  std::vector<int32_t> slot_offsets;  ///< per block + 1: its slots, kLanes entries each
  AlignedVector<int32_t> other4;      ///< per entry, as SpringLanes::other4
  AlignedVector<float> inverse_rest, k_rest;
  std::vector<int64_t> entry;       ///< per entry: the model layout's it copies (-1: padding)
  std::vector<int32_t> read_nodes;  ///< the nodes the blocks read, ascending
};

struct SpringLanes {
  int32_t nodes = 0;
  double centre[3] = {0.0, 0.0, 0.0};  ///< subtracted before rounding to float (precision)
  std::vector<int32_t> slot_offsets;   ///< per block + 1: its slots, kLanes entries each
  AlignedVector<int32_t> other4;       ///< per entry: 4 x the node at the other end
  AlignedVector<float> inverse_rest;   ///< per entry: 1 / L, 1/mm (0 on padding)
  AlignedVector<float> k_rest;         ///< per entry: k L, mN (0 on padding)
  std::vector<double> rest_mm;         ///< per entry: L (to refill k_rest)
  std::vector<int32_t> spring;         ///< per entry: the spring (-1: padding), to refill k
  AlignedVector<float> p;              ///< 4 floats per node: x - centre, the pass's positions
  AlignedVector<double> movable;       ///< per node: 1 = integrated (Solver::movable, as doubles)
  std::vector<int32_t> active_blocks;  ///< blocks with a movable node (refresh())
  /// Work before each active block (its slots, plus two for its nodes' update), and the total
  /// at the end: threads split the blocks by work, not by count.
  std::vector<int64_t> work_before;
  std::vector<int32_t> read_nodes;  ///< the nodes those blocks read, ascending
  bool reads_all = true;            ///< read_nodes is every node (global mode)
  LocalLanes local;                 ///< the explicit step's blocks in local mode

  // Implicit Euler's products K p on the same layout (spring_lanes_product.h), sized only for
  // implicit Euler on springs (refresh()).
  /// Per slot, kLanes floats each of w_x, w_y, w_z and k alpha: the spring's linearised
  /// stiffness k [alpha I + (1 - alpha) u u^T] = k alpha I + w w^T, w = sqrt(k (1 - alpha)) u.
  AlignedVector<float> product;
  AlignedVector<double> packed;     ///< 4 doubles per node: positions or p, x y z _
  AlignedVector<double> stiffness;  ///< per entry: k, N/m (0 on padding)
  AlignedVector<double> force;      ///< the springs' force at the linearisation: x, y, z columns
};

inline int32_t block_count(int32_t nodes) {
  return (nodes + kLanes - 1) / kLanes;
}

/// The lanes' layout from the model's springs, and the rest lengths (resolve(), once the
/// springs step by themselves: not while tetrahedra carry them; refresh_spring_lanes() then
/// leaves them unmade).
void setup_spring_lanes(Solver& s);
/// The lanes' stiffness from springs.stiffness_n_per_m (whenever the material resolves it, and
/// when refresh() sizes implicit Euler's tables).
void fill_spring_lanes(Solver& s);
/// active_blocks and read_nodes from the movable nodes, and the products' tables (refresh()).
void refresh_spring_lanes(Solver& s);

/// The first active block of thread k of n: the blocks split by work (SpringLanes::work_before).
inline int64_t first_block(const SpringLanes& t, int k, int n) {
  const int64_t target = t.work_before.back() * k / n;
  return std::lower_bound(t.work_before.begin(), t.work_before.end() - 1, target) -
         t.work_before.begin();
}

/// Node q's position for the pass: x - centre, rounded to float.
inline void pack_position(SpringLanes& t, int32_t q, double x, double y, double z) {
  float* p = t.p.data() + 4 * static_cast<int64_t>(q);
  p[0] = static_cast<float>(x - t.centre[0]);
  p[1] = static_cast<float>(y - t.centre[1]);
  p[2] = static_cast<float>(z - t.centre[2]);
}

}  // namespace lamina::sim::detail
