#pragma once
// Implicit Euler's spring products on the lanes' layout (spring_lanes.h): (K p)_i for a block of
// kLanes consecutive nodes at a time, one SIMD lane per node, in double. Each slot streams its
// entries' other ends and linearised stiffness (SpringLanes::product, filled once a step by
// fill_product_lanes) and gathers p at the other ends from a packed copy, x y z in one cache
// line per node. The scalar product over the CSR (spring_product) read, per entry, the spring's
// direction and stiffness from wherever the spring lay and p from three columns: four lines.

#include "solver.h"
#include "spring_lanes_kernel.h"

namespace lamina::sim::detail {

using DoubleLanes = xsimd::batch<double>;
constexpr int32_t kHalf = static_cast<int32_t>(DoubleLanes::size);  // doubles per register
static_assert(kLanes == 2 * kHalf, "a block of float lanes is two registers of doubles");

/// Whether implicit Euler's products take the lanes: springs (not tetrahedra), the tables sized
/// (refresh_spring_lanes) and at least half the lanes of the active blocks in use (local mode's
/// scattered few nodes keep the CSR).
bool product_lanes_apply(const Solver& s);
/// The springs' linearisation at x on the lanes, in place of spring_linearise(): per entry of
/// the active blocks, SpringLanes::product (w and k alpha, alpha = max(0, 1 - L/l)), and per
/// node the springs' force, SpringLanes::force. One parallel region: pack x, then the blocks.
void linearise_lanes(Solver& s, const Eigen::MatrixX3d& x, int threads);
/// The springs' force on node i from linearise_lanes(), added to f.
inline void gather_lane_force(const Solver& s, int32_t i, double& fx, double& fy, double& fz) {
  const double* f = s.lanes.force.data();
  const int64_t n = s.lanes.nodes;
  fx += f[i], fy += f[n + i], fz += f[2 * n + i];
}
/// Node i's row of p into `packed` (4 doubles a node: SpringLanes::packed, TetAssembly::packed).
inline void pack_vector(double* packed, const ConstCols& p, int64_t i) {
  double* q = packed + 4 * i;
  q[0] = p.x[i], q[1] = p.y[i], q[2] = p.z[i];
}

/// base[index[q]] (index in doubles) in each lane q of a register of doubles.
inline DoubleLanes gather_doubles(const double* base, const int32_t* index) {
#if defined(__AVX512F__)
  return _mm512_i32gather_pd(_mm256_load_si256(reinterpret_cast<const __m256i*>(index)), base, 8);
#elif defined(__AVX2__)
  return _mm256_i32gather_pd(base, _mm_load_si128(reinterpret_cast<const __m128i*>(index)), 8);
#else
  alignas(64) double v[kHalf];
  for (int32_t q = 0; q < kHalf; ++q) v[q] = base[index[q]];
  return DoubleLanes::load_aligned(v);
#endif
}

/// kHalf floats (aligned) widened to doubles.
inline DoubleLanes widen(const float* p) {
#if defined(__AVX512F__)
  return _mm512_cvtps_pd(_mm256_load_ps(p));
#elif defined(__AVX__)
  return _mm256_cvtps_pd(_mm_load_ps(p));
#else
  alignas(64) double v[kHalf];
  for (int32_t q = 0; q < kHalf; ++q) v[q] = p[q];
  return DoubleLanes::load_aligned(v);
#endif
}

/// kHalf doubles narrowed to floats, stored aligned.
inline void narrow(const DoubleLanes& v, float* p) {
#if defined(__AVX512F__)
  _mm256_store_ps(p, _mm512_cvtpd_ps(v));
#elif defined(__AVX__)
  _mm_store_ps(p, _mm256_cvtpd_ps(v));
#else
  alignas(64) double d[kHalf];
  v.store_aligned(d);
  for (int32_t q = 0; q < kHalf; ++q) p[q] = static_cast<float>(d[q]);
#endif
}

/// Block b's (K p) into k[3][kLanes], and with kDiagonal K's diagonal into d[3][kLanes], from
/// SpringLanes::packed: per entry k alpha (p_i - p_j) + w (w . (p_i - p_j)). Padding entries
/// point at the node itself with no stiffness, and add zero.
template <bool kDiagonal>
inline void block_spring_product(const SpringLanes& t, int32_t b, double (*k)[kLanes],
                                 double (*d)[kLanes]) {
  const double* p = t.packed.data();
  alignas(64) int32_t own[kLanes];
  for (int32_t q = 0; q < kLanes; ++q) own[q] = 4 * std::min(b * kLanes + q, t.nodes - 1);
  DoubleLanes px[2], py[2], pz[2], ax[2], ay[2], az[2], dx[2], dy[2], dz[2];
  for (int h = 0; h < 2; ++h) {
    px[h] = gather_doubles(p, own + h * kHalf), py[h] = gather_doubles(p + 1, own + h * kHalf),
    pz[h] = gather_doubles(p + 2, own + h * kHalf);
    ax[h] = ay[h] = az[h] = dx[h] = dy[h] = dz[h] = DoubleLanes(0.0);
  }
  for (int64_t e = int64_t{t.slot_offsets[b]} * kLanes,
               end = int64_t{t.slot_offsets[b + 1]} * kLanes;
       e < end; e += kLanes) {
    const float* c = t.product.data() + 4 * e;  // the slot's w_x, w_y, w_z, k alpha
    for (int h = 0; h < 2; ++h) {
      const int32_t* index = t.other4.data() + e + h * kHalf;
      const DoubleLanes ex = px[h] - gather_doubles(p, index),
                        ey = py[h] - gather_doubles(p + 1, index),
                        ez = pz[h] - gather_doubles(p + 2, index);
      const int32_t o = h * kHalf;
      const DoubleLanes wx = widen(c + o), wy = widen(c + kLanes + o),
                        wz = widen(c + 2 * kLanes + o), ka = widen(c + 3 * kLanes + o);
      const DoubleLanes along = xsimd::fma(wx, ex, xsimd::fma(wy, ey, wz * ez));
      ax[h] = xsimd::fma(ka, ex, xsimd::fma(along, wx, ax[h]));
      ay[h] = xsimd::fma(ka, ey, xsimd::fma(along, wy, ay[h]));
      az[h] = xsimd::fma(ka, ez, xsimd::fma(along, wz, az[h]));
      if constexpr (kDiagonal) {
        dx[h] = xsimd::fma(wx, wx, dx[h] + ka), dy[h] = xsimd::fma(wy, wy, dy[h] + ka);
        dz[h] = xsimd::fma(wz, wz, dz[h] + ka);
      }
    }
  }
  for (int h = 0; h < 2; ++h) {
    ax[h].store_aligned(k[0] + h * kHalf), ay[h].store_aligned(k[1] + h * kHalf),
        az[h].store_aligned(k[2] + h * kHalf);
    if constexpr (kDiagonal)
      dx[h].store_aligned(d[0] + h * kHalf), dy[h].store_aligned(d[1] + h * kHalf),
          dz[h].store_aligned(d[2] + h * kHalf);
  }
}

/// for_spring_products() on the tetrahedra's assembled blocks: one parallel region, p packed
/// by node (TetAssembly::packed, every node: a row reads any neighbour), then the movable nodes
/// in slices.
template <bool kDiagonal, class Body>
void for_assembled_products(Solver& s, const ConstCols& p, int threads, Partials& part,
                            Body&& body) {
  TetAssembly& a = s.tets.assembly;
  const auto n = static_cast<int64_t>(a.offsets.size()) - 1;
  const auto nodes = static_cast<int64_t>(s.active_nodes.size());
  auto run = [&](int th, int T) {
    double* packed = a.packed.data();
    for (int64_t i = n * th / T, end = n * (th + 1) / T; i < end; ++i) pack_vector(packed, p, i);
    if (T > 1) {
#pragma omp barrier
    }
    Partial acc;
    for (int64_t q = nodes * th / T, end = nodes * (th + 1) / T; q < end; ++q) {
      const int32_t i = s.active_nodes[q];
      double k[3] = {0.0, 0.0, 0.0}, d[3] = {0.0, 0.0, 0.0};
      assembled_tet_product_packed(a, i, packed, k);
      if constexpr (kDiagonal) gather_tets(s, s.tets.diag, i, d[0], d[1], d[2]);
      body(i, k, d, acc);
    }
    part[th] = acc;
  };
  on_threads(threads, run);
}

/// Runs body(i, k, d, acc) for every movable node i, with k its springs' (K p)_i and d (with
/// kDiagonal) their diagonal of K, and acc its thread's partial results (into part[thread]).
/// Through the lanes where they apply (one parallel region: pack p, then blocks split by work),
/// else node by node over the CSR; with tetrahedra, their product and diagonal (tets.product
/// and tets.diag, which tet_product_pass and tet_pass fill beforehand; or, assembled, the
/// product from tets.assembly).
template <bool kDiagonal, class Body>
void for_spring_products(Solver& s, const Eigen::MatrixX3d& pm, int threads, Partials& part,
                         Body&& body) {
  const ConstCols p(pm);
  if (s.tets.on && s.tets.assembly.current) {  // the tetrahedra's assembled blocks
    for_assembled_products<kDiagonal>(s, p, threads, part, body);
    return;
  }
  if (!product_lanes_apply(s)) {
    for_slices(static_cast<int64_t>(s.active_nodes.size()), threads,
               [&](int64_t begin, int64_t end, int th) {
                 Partial acc;
                 for (int64_t q = begin; q < end; ++q) {
                   const int32_t i = s.active_nodes[q];
                   double k[3] = {0.0, 0.0, 0.0}, d[3] = {0.0, 0.0, 0.0};
                   if (s.tets.on) {  // the springs are the tetrahedra's edges
                     gather_tets(s, s.tets.product, i, k[0], k[1], k[2]);
                     if constexpr (kDiagonal) gather_tets(s, s.tets.diag, i, d[0], d[1], d[2]);
                   } else {
                     spring_product(s, i, p, k[0], k[1], k[2]);
                     if constexpr (kDiagonal) spring_diagonal(s, i, d[0], d[1], d[2]);
                   }
                   body(i, k, d, acc);
                 }
                 part[th] = acc;
               });
    return;
  }
  SpringLanes& t = s.lanes;
  const int64_t reads = t.reads_all ? t.nodes : static_cast<int64_t>(t.read_nodes.size());
  auto run = [&](int th, int n) {
    for (int64_t q = reads * th / n, end = reads * (th + 1) / n; q < end; ++q)
      pack_vector(t.packed.data(), p, t.reads_all ? q : t.read_nodes[q]);
    if (n > 1) {
#pragma omp barrier
    }
    Partial acc;
    alignas(64) double k[3][kLanes], d[3][kLanes];
    for (int64_t a = first_block(t, th, n), end = first_block(t, th + 1, n); a < end; ++a) {
      const int32_t b = t.active_blocks[a];
      block_spring_product<kDiagonal>(t, b, k, d);
      for (int32_t i = b * kLanes, last = std::min(t.nodes, i + kLanes); i < last; ++i) {
        if (!s.movable[i]) continue;
        const int32_t q = i - b * kLanes;
        const double kq[3] = {k[0][q], k[1][q], k[2][q]};
        double dq[3] = {0.0, 0.0, 0.0};
        if constexpr (kDiagonal) dq[0] = d[0][q], dq[1] = d[1][q], dq[2] = d[2][q];
        body(i, kq, dq, acc);
      }
    }
    part[th] = acc;
  };
  on_threads(threads, run);
}

}  // namespace lamina::sim::detail
