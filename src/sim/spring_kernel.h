#pragma once
/// \file
/// The explicit step's spring pass as a plain function over raw arrays: sim::step runs it in
/// double; bench/kernels_bench also runs it in float to measure what single precision would buy.

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace lamina::sim {

/// Hooke force of springs [begin, end) (of `list`, or all springs when it is null) on their
/// first node i, k (l - L) (x_j - x_i) / l, into f (one entry per spring). Each spring is
/// evaluated once; a node then gathers +f (as i) or -f (as j), so forces on the two ends are
/// exactly opposite and no two threads write the same value. Restrict-qualified plain loops with
/// contiguous stores, so that the compiler vectorises the dense case (docs/benchmarks.md).
template <class Real>
void spring_kernel(int64_t begin, int64_t end, const int32_t* __restrict list,
                   const int32_t* __restrict si, const int32_t* __restrict sj,
                   const Real* __restrict rest, const Real* __restrict k, const Real* __restrict px,
                   const Real* __restrict py, const Real* __restrict pz, Real* __restrict fx,
                   Real* __restrict fy, Real* __restrict fz) {
  // A zero-length spring has no direction: |d| / l <= 1 keeps its force bounded (0 at d = 0).
  constexpr Real kShortest = Real(1e-12);
  // Written out twice (not as a lambda): a lambda's by-reference captures drop __restrict.
  if (!list) {
    for (int64_t e = begin; e < end; ++e) {
      const int32_t a = si[e], b = sj[e];
      const Real dx = px[b] - px[a], dy = py[b] - py[a], dz = pz[b] - pz[a];
      const Real l = std::max(std::sqrt(dx * dx + dy * dy + dz * dz), kShortest);
      const Real t = k[e] * (l - rest[e]) / l;
      fx[e] = t * dx, fy[e] = t * dy, fz[e] = t * dz;
    }
    return;
  }
  for (int64_t q = begin; q < end; ++q) {
    const int64_t e = list[q];
    const int32_t a = si[e], b = sj[e];
    const Real dx = px[b] - px[a], dy = py[b] - py[a], dz = pz[b] - pz[a];
    const Real l = std::max(std::sqrt(dx * dx + dy * dy + dz * dz), kShortest);
    const Real t = k[e] * (l - rest[e]) / l;
    fx[e] = t * dx, fy[e] = t * dy, fz[e] = t * dz;
  }
}

}  // namespace lamina::sim
