#pragma once
// Trilinear sampling of a float grid (internal to src/geometry: the display skin's distance
// resampled, the Couinaud atlas's votes read at each voxel).
#include <algorithm>
#include <array>
#include <cstdint>

namespace lamina::geometry::detail {

/// `values` (size[0] x size[1] x size[2], i fastest) at continuous index (x, y, z), clamped to
/// the grid: points beyond it take the border's values.
inline float sample_trilinear(const float* values, const std::array<int64_t, 3>& size, double x,
                              double y, double z) {
  const auto& n = size;
  const double p[3] = {std::clamp(x, 0.0, static_cast<double>(n[0] - 1)),
                       std::clamp(y, 0.0, static_cast<double>(n[1] - 1)),
                       std::clamp(z, 0.0, static_cast<double>(n[2] - 1))};
  int64_t c[3];
  double t[3];
  for (int a = 0; a < 3; ++a) {
    c[a] = std::min(static_cast<int64_t>(p[a]), std::max<int64_t>(n[a] - 2, 0));
    t[a] = p[a] - static_cast<double>(c[a]);
  }
  const auto at = [&](int64_t di, int64_t dj, int64_t dk) {
    const int64_t i = std::min(c[0] + di, n[0] - 1), j = std::min(c[1] + dj, n[1] - 1),
                  k = std::min(c[2] + dk, n[2] - 1);
    return static_cast<double>(values[i + n[0] * (j + n[1] * k)]);
  };
  const auto lerp = [](double a, double b, double s) { return a + s * (b - a); };
  const double y0 =
      lerp(lerp(at(0, 0, 0), at(1, 0, 0), t[0]), lerp(at(0, 1, 0), at(1, 1, 0), t[0]), t[1]);
  const double y1 =
      lerp(lerp(at(0, 0, 1), at(1, 0, 1), t[0]), lerp(at(0, 1, 1), at(1, 1, 1), t[0]), t[1]);
  return static_cast<float>(lerp(y0, y1, t[2]));
}

}  // namespace lamina::geometry::detail
