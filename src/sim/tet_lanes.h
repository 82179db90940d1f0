#pragma once
// A block of kTetLanes tetrahedra's values as one SIMD value per field (internal to module sim):
// what the tetrahedral energies' passes (tet_term.cpp, neo_hookean_term.cpp) share.

#include <immintrin.h>

#include <cmath>

#include "solver.h"

namespace lamina::sim::detail::lanes_of_tets {

constexpr int L = kTetLanes;

// A block's lanes as one value: GCC's and Clang's vector extensions, which compile to one
// AVX-512 (8 lanes) or AVX2 (4 lanes) instruction per operation. Written out rather than
// left to the auto-vectoriser, which vectorised these loops only in part (-fopt-info-vec:
// docs/architecture.md has the measurement).
typedef double Lanes __attribute__((vector_size(8 * L)));
typedef float LanesF __attribute__((vector_size(4 * L)));

inline Lanes lanes(const double* p) {
  Lanes v;
  __builtin_memcpy(&v, p, sizeof v);
  return v;
}
// Floats to and from a block's double lanes: one vcvtps2pd (vcvtpd2ps) with its load (store).
// GCC 12 lowers __builtin_convertvector between these widths in halves, through extracts and
// inserts (and on AVX2 through the stack): five instructions a value in block_product's 66
// conversions (objdump; issue 48, docs/benchmarks.md has the kernels' times before and after).
inline Lanes lanes(const float* p) {
#if defined(__AVX512F__)
  static_assert(L == 8);
  return Lanes(_mm512_cvtps_pd(_mm256_loadu_ps(p)));
#elif defined(__AVX__)
  static_assert(L == 4);
  return Lanes(_mm256_cvtps_pd(_mm_loadu_ps(p)));
#else
  LanesF v;
  __builtin_memcpy(&v, p, sizeof v);
  return __builtin_convertvector(v, Lanes);
#endif
}
inline void store(Lanes v, double* p) {
  __builtin_memcpy(p, &v, sizeof v);
}
inline void store(Lanes v, float* p) {
#if defined(__AVX512F__)
  _mm256_storeu_ps(p, _mm512_cvtpd_ps(__m512d(v)));
#elif defined(__AVX__)
  _mm_storeu_ps(p, _mm256_cvtpd_ps(__m256d(v)));
#else
  const LanesF f = __builtin_convertvector(v, LanesF);
  __builtin_memcpy(p, &f, sizeof f);
#endif
}
inline Lanes splat(double x) {
  return Lanes{} + x;
}
inline Lanes sqrt(Lanes v) {
  Lanes r;
  for (int l = 0; l < L; ++l) r[l] = std::sqrt(v[l]);  // one vsqrtpd
  return r;
}
inline Lanes max(Lanes a, Lanes b) {
  return a > b ? a : b;
}

// The corners' values (positions, or a CG direction) of a block: corner c, axis d at p[3 c + d].
inline void load_corners(const TetBlock& b, const ConstCols& x, Lanes p[12]) {
  for (int c = 0; c < 4; ++c) {
    const int32_t* n = b.node[c];
    for (int d = 0; d < 3; ++d) {
      const double* col = d == 0 ? x.x : d == 1 ? x.y : x.z;
      Lanes v;
      for (int l = 0; l < L; ++l) v[l] = col[n[l]];
      p[3 * c + d] = v;
    }
  }
}

// A block's lane-major values into its tetrahedra's rows (12 t + 3 c + d).
inline void store_rows(const Lanes v[12], float* rows) {
  for (int l = 0; l < L; ++l)
    for (int k = 0; k < 12; ++k) rows[12 * l + k] = static_cast<float>(v[k][l]);
}

}  // namespace lamina::sim::detail::lanes_of_tets
