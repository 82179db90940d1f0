// Implicit Euler's spring products on the lanes (spring_lanes_product.h): when they apply, and
// the per-entry linearised stiffness, filled once a step.
#include "spring_lanes_product.h"

#include <algorithm>
#include <cmath>

namespace lamina::sim::detail {

bool product_lanes_apply(const Solver& s) {
  const SpringLanes& t = s.lanes;
  const auto lanes_used = static_cast<size_t>(kLanes) * t.active_blocks.size();
  return !s.tets.on && !t.product.empty() && 2 * s.active_nodes.size() >= lanes_used;
}

// Entry by entry of the active blocks, from the spring's direction u and alpha = max(0, 1 - L/l)
// (SpringTerm::dir, in float already) and its stiffness k: w = sqrt(k (1 - alpha)) u and
// k alpha. A padding entry (no spring) stays zero.
void fill_product_lanes(Solver& s, int threads) {
  SpringLanes& t = s.lanes;
  const float* dir = s.springs.dir.data();
  const double* stiffness = s.springs.stiffness_n_per_m.data();
  const auto blocks = static_cast<int64_t>(t.active_blocks.size());
  for_slices(blocks, threads, [&](int64_t begin, int64_t end, int) {
    for (int64_t a = begin; a < end; ++a) {
      const int32_t b = t.active_blocks[a];
      for (int64_t slot = t.slot_offsets[b]; slot < t.slot_offsets[b + 1]; ++slot) {
        float* c = t.product.data() + 4 * kLanes * slot;
        for (int32_t q = 0; q < kLanes; ++q) {
          const int32_t e = t.spring[slot * kLanes + q];
          if (e < 0) continue;
          const float* u = dir + 4 * static_cast<int64_t>(e);
          const double k = stiffness[e], ka = k * u[3], root = std::sqrt(std::max(0.0, k - ka));
          c[q] = static_cast<float>(root * u[0]);
          c[kLanes + q] = static_cast<float>(root * u[1]);
          c[2 * kLanes + q] = static_cast<float>(root * u[2]);
          c[3 * kLanes + q] = static_cast<float>(ka);
        }
      }
    }
  });
}

}  // namespace lamina::sim::detail
