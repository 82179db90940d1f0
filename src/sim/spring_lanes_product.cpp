// Implicit Euler's springs on the lanes (spring_lanes_product.h): when they apply, and their
// linearisation once a step (the force and each entry's linearised stiffness).
#include "spring_lanes_product.h"

#include <omp.h>

#include <algorithm>
#include <cmath>

namespace lamina::sim::detail {

bool product_lanes_apply(const Solver& s) {
  const SpringLanes& t = s.lanes;
  const auto lanes_used = static_cast<size_t>(kLanes) * t.active_blocks.size();
  return !s.tets.on && !t.product.empty() && 2 * s.active_nodes.size() >= lanes_used;
}

namespace {

// Block b: each entry's spring at the packed positions, d = x_j - x_i, l = |d| (at least
// 1e-12 mm), as spring_linearise() has it: the force k (1 - L/l) d summed on the node's lane, and
// w = sqrt(k (1 - alpha)) d / l and k alpha into the entry's product table.
void block_linearise(SpringLanes& t, int32_t b, double (*f)[kLanes]) {
  using D = DoubleLanes;
  const double* x = t.packed.data();
  alignas(64) int32_t own[kLanes];
  for (int32_t q = 0; q < kLanes; ++q) own[q] = 4 * std::min(b * kLanes + q, t.nodes - 1);
  D px[2], py[2], pz[2], fx[2], fy[2], fz[2];
  for (int h = 0; h < 2; ++h) {
    px[h] = gather_doubles(x, own + h * kHalf), py[h] = gather_doubles(x + 1, own + h * kHalf),
    pz[h] = gather_doubles(x + 2, own + h * kHalf);
    fx[h] = fy[h] = fz[h] = D(0.0);
  }
  for (int64_t e = int64_t{t.slot_offsets[b]} * kLanes,
               end = int64_t{t.slot_offsets[b + 1]} * kLanes;
       e < end; e += kLanes) {
    float* c = t.product.data() + 4 * e;
    for (int h = 0; h < 2; ++h) {
      const int32_t o = h * kHalf;
      const int32_t* index = t.other4.data() + e + o;
      const D dx = gather_doubles(x, index) - px[h], dy = gather_doubles(x + 1, index) - py[h],
              dz = gather_doubles(x + 2, index) - pz[h];
      const D l =
          xsimd::max(xsimd::sqrt(xsimd::fma(dx, dx, xsimd::fma(dy, dy, dz * dz))), D(1e-12));
      const D inverse = D(1.0) / l;  // one division for the two uses
      const D k = D::load_aligned(t.stiffness.data() + e + o);
      const D ratio = D::load_unaligned(t.rest_mm.data() + e + o) * inverse;  // L / l
      const D tension = k * (D(1.0) - ratio);
      fx[h] = xsimd::fma(tension, dx, fx[h]), fy[h] = xsimd::fma(tension, dy, fy[h]),
      fz[h] = xsimd::fma(tension, dz, fz[h]);
      const D ka = k * xsimd::max(D(0.0), D(1.0) - ratio);
      const D scale = xsimd::sqrt(xsimd::max(D(0.0), k - ka)) * inverse;
      narrow(scale * dx, c + o), narrow(scale * dy, c + kLanes + o);
      narrow(scale * dz, c + 2 * kLanes + o), narrow(ka, c + 3 * kLanes + o);
    }
  }
  for (int h = 0; h < 2; ++h)
    fx[h].store_aligned(f[0] + h * kHalf), fy[h].store_aligned(f[1] + h * kHalf),
        fz[h].store_aligned(f[2] + h * kHalf);
}

}  // namespace

void linearise_lanes(Solver& s, const Eigen::MatrixX3d& xm, int threads) {
  SpringLanes& t = s.lanes;
  const ConstCols x(xm);
  const int64_t reads = t.reads_all ? t.nodes : static_cast<int64_t>(t.read_nodes.size());
  const int64_t n = t.nodes;
  auto run = [&](int th, int count) {
    for (int64_t q = reads * th / count, end = reads * (th + 1) / count; q < end; ++q)
      pack_vector(t.packed.data(), x, t.reads_all ? q : t.read_nodes[q]);
    if (count > 1) {
#pragma omp barrier
    }
    alignas(64) double f[3][kLanes];
    for (int64_t a = first_block(t, th, count), end = first_block(t, th + 1, count); a < end; ++a) {
      const int32_t b = t.active_blocks[a];
      block_linearise(t, b, f);
      for (int32_t i = b * kLanes, last = std::min(t.nodes, i + kLanes); i < last; ++i) {
        const int32_t q = i - b * kLanes;
        t.force[i] = f[0][q], t.force[n + i] = f[1][q], t.force[2 * n + i] = f[2][q];
      }
    }
  };
  on_threads(threads, run);
}

}  // namespace lamina::sim::detail
