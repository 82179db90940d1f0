#pragma once
// The lanes' SIMD arithmetic (xsimd), for the files that run it (spring_lanes.h has the layout).

#include <xsimd/xsimd.hpp>

#include "spring_lanes.h"

namespace lamina::sim::detail {

using FloatLanes = xsimd::batch<float>;
using IndexLanes = xsimd::batch<int32_t>;
static_assert(kLanes == static_cast<int32_t>(FloatLanes::size), "kLanes is xsimd's float width");

/// base[index[q]] in each lane q. xsimd 8.1 gathers floats element by element (a call per
/// gather, measured at 28% of a step); the CPU's gather instruction where there is one.
inline FloatLanes gather_lanes(const float* base, const IndexLanes& index) {
#if defined(__AVX512F__)
  return _mm512_i32gather_ps(index, base, 4);
#elif defined(__AVX2__)
  return _mm256_i32gather_ps(base, index, 4);
#else
  return FloatLanes::gather(base, index);
#endif
}

/// 1 / |d| in the pass's arithmetic (the same for rest lengths and the pass): the CPU's
/// reciprocal square root estimate (14 bits on AVX-512, 12 on AVX) and one Newton step (to
/// about float precision), in place of a square root and a division, the two slowest
/// instructions of the pass. |d| is taken as at least 1e-12 mm: a zero-length spring has no
/// direction, and its force k L (1/L - 1/|d|) d stays bounded (0 at d = 0).
inline FloatLanes inverse_length(const FloatLanes& dx, const FloatLanes& dy, const FloatLanes& dz) {
  const FloatLanes d2 =
      xsimd::max(xsimd::fma(dx, dx, xsimd::fma(dy, dy, dz * dz)), FloatLanes(1e-24f));
#if defined(__AVX512F__)
  const FloatLanes r = _mm512_rsqrt14_ps(d2);
#elif defined(__AVX__)
  const FloatLanes r = _mm256_rsqrt_ps(d2);
#else
  const FloatLanes r = FloatLanes(1.0f) / xsimd::sqrt(d2);
#endif
  // The last product as a fused multiply-add of zero: the compiler may otherwise fuse it into
  // the pass's 1/L - 1/l (one rounding there, two at rest), and a network at rest would move.
  return xsimd::fma(r, xsimd::fnma(FloatLanes(0.5f) * d2, r * r, FloatLanes(1.5f)),
                    FloatLanes(0.0f));
}

/// Positions of the nodes q / 4 (4 x the node in each lane) from the packed copy: x and y as one
/// 64-bit element (two 8-lane gathers), z alone, then x and y separated by two permutes: 32
/// elements fetched instead of 48, and gathers cost by the element.
inline void gather_positions(const float* p, const IndexLanes& node4, FloatLanes& x, FloatLanes& y,
                             FloatLanes& z) {
#if defined(__AVX512F__)
  const __m512i node2 = _mm512_srli_epi32(node4, 1);  // in units of two floats
  const __m512d lo = _mm512_i32gather_pd(_mm512_castsi512_si256(node2), p, 8);
  const __m512d hi = _mm512_i32gather_pd(_mm512_extracti32x8_epi32(node2, 1), p, 8);
  const __m512i even = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
  const __m512i odd = _mm512_setr_epi32(1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31);
  x = _mm512_permutex2var_ps(_mm512_castpd_ps(lo), even, _mm512_castpd_ps(hi));
  y = _mm512_permutex2var_ps(_mm512_castpd_ps(lo), odd, _mm512_castpd_ps(hi));
  z = gather_lanes(p + 2, node4);
#else
  x = gather_lanes(p, node4), y = gather_lanes(p + 1, node4), z = gather_lanes(p + 2, node4);
#endif
}

/// The spring force (mN) on the nodes 4 x own4[q] of one block, whose slots are entries
/// [begin, end) of other4, k_rest and inverse_rest, from the packed positions p, into f[kLanes].
inline void lanes_spring_force(const float* p, const int32_t* own4, const int32_t* other4,
                               const float* k_rest, const float* inverse_rest, int64_t begin,
                               int64_t end, float* __restrict fx, float* __restrict fy,
                               float* __restrict fz) {
  FloatLanes px, py, pz;
  gather_positions(p, IndexLanes::load_aligned(own4), px, py, pz);
  FloatLanes ax(0.0f), ay(0.0f), az(0.0f);
  for (int64_t e = begin; e < end; e += kLanes) {
    FloatLanes qx, qy, qz;
    gather_positions(p, IndexLanes::load_aligned(other4 + e), qx, qy, qz);
    const FloatLanes dx = qx - px, dy = qy - py, dz = qz - pz;
    // k (l - L) / l = k L (1/L - 1/l): zero at rest, where 1/l is 1/L in the same arithmetic.
    const FloatLanes tension =
        FloatLanes::load_aligned(k_rest + e) *
        (FloatLanes::load_aligned(inverse_rest + e) - inverse_length(dx, dy, dz));
    ax = xsimd::fma(tension, dx, ax), ay = xsimd::fma(tension, dy, ay),
    az = xsimd::fma(tension, dz, az);
  }
  ax.store_aligned(fx), ay.store_aligned(fy), az.store_aligned(fz);
}

/// The spring force on each node of the model's block b (mN), from the packed positions.
inline void block_spring_force(const SpringLanes& t, int32_t b, float* __restrict fx,
                               float* __restrict fy, float* __restrict fz) {
  alignas(64) int32_t own[kLanes];
  for (int32_t q = 0; q < kLanes; ++q) own[q] = 4 * std::min(b * kLanes + q, t.nodes - 1);
  lanes_spring_force(t.p.data(), own, t.other4.data(), t.k_rest.data(), t.inverse_rest.data(),
                     int64_t{t.slot_offsets[b]} * kLanes, int64_t{t.slot_offsets[b + 1]} * kLanes,
                     fx, fy, fz);
}

/// The spring force on each node of local block b (LocalLanes), from the packed positions.
inline void local_block_spring_force(const SpringLanes& t, int32_t b, float* __restrict fx,
                                     float* __restrict fy, float* __restrict fz) {
  const LocalLanes& l = t.local;
  lanes_spring_force(t.p.data(), l.own4.data() + int64_t{b} * kLanes, l.other4.data(),
                     l.k_rest.data(), l.inverse_rest.data(), int64_t{l.slot_offsets[b]} * kLanes,
                     int64_t{l.slot_offsets[b + 1]} * kLanes, fx, fy, fz);
}

}  // namespace lamina::sim::detail
