// Separable Gaussian smoothing (smooth_grid.h). Along each axis the grid is [outer][n][inner]
// with inner contiguous, so every tap is one run of `inner` floats the compiler vectorises;
// along the fastest axis (inner = 1) it is a plain line filter.
#include "smooth_grid.h"

#include <cmath>
#include <numeric>

namespace lamina::geometry::detail {

std::vector<float> gaussian_kernel(double sigma) {
  const int r = static_cast<int>(std::ceil(4.0 * sigma));
  std::vector<float> k;
  for (int i = -r; i <= r; ++i)
    k.push_back(static_cast<float>(std::exp(-0.5 * i * i / (sigma * sigma))));
  const float sum = std::accumulate(k.begin(), k.end(), 0.0F);
  for (float& w : k) w /= sum;
  return k;
}

void smooth_grid(std::vector<float>& values, const std::array<int64_t, 3>& size,
                 const std::vector<float>& kernel, std::vector<float>& scratch) {
  const int64_t r = static_cast<int64_t>(kernel.size()) / 2;
  const float* w = kernel.data();
  scratch.resize(values.size());
  const auto mirror = [](int64_t i, int64_t n) {
    while (i < 0 || i >= n) i = i < 0 ? -i - 1 : 2 * n - i - 1;
    return i;
  };
  // Along the fastest axis: each line copied with its mirrored margins, then a plain filter.
  {
    const int64_t n = size[0];
    std::vector<float> line(static_cast<size_t>(n + 2 * r));
    for (int64_t o = 0; o < static_cast<int64_t>(values.size()) / n; ++o) {
      const float* in = values.data() + o * n;
      for (int64_t i = -r; i < n + r; ++i) line[static_cast<size_t>(i + r)] = in[mirror(i, n)];
      float* __restrict out = scratch.data() + o * n;
      const float* __restrict l = line.data();
      for (int64_t i = 0; i < n; ++i) out[i] = 0.0F;
      for (int64_t k = 0; k <= 2 * r; ++k)  // taps outside, so the line's loop vectorises
        for (int64_t i = 0; i < n; ++i) out[i] += w[k] * l[i + k];
    }
    values.swap(scratch);
  }
  // Along the others: every tap adds a whole contiguous run (a row, or a plane) at once.
  int64_t inner = size[0];
  for (int axis = 1; axis < 3; ++axis) {
    const int64_t n = size[static_cast<size_t>(axis)];
    const int64_t outer = static_cast<int64_t>(values.size()) / (n * inner);
    for (int64_t o = 0; o < outer; ++o)
      for (int64_t i = 0; i < n; ++i) {
        float* __restrict dst = scratch.data() + (o * n + i) * inner;
        for (int64_t e = 0; e < inner; ++e) dst[e] = 0.0F;
        for (int64_t k = -r; k <= r; ++k) {
          const float wk = w[k + r];
          const float* __restrict src = values.data() + (o * n + mirror(i + k, n)) * inner;
          for (int64_t e = 0; e < inner; ++e) dst[e] += wk * src[e];
        }
      }
    values.swap(scratch);
    inner *= n;
  }
}

}  // namespace lamina::geometry::detail
