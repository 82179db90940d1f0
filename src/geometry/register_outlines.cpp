// Outline registration by demons (register_outlines.h): Thirion, "Image matching as a diffusion
// process" (Medical Image Analysis 2, 1998), on signed distances rather than intensities, so
// the force is defined everywhere near the outline and its size is a distance in voxels. The
// atlas runs it on 48^3 bins for each of its voting livers (docs/resection.md).
#include "register_outlines.h"

#include <algorithm>
#include <cmath>

#include "lamina/geometry/mask_filters.h"
#include "smooth_grid.h"

namespace lamina::geometry::detail {

std::vector<float> signed_distance_voxels(const std::vector<uint8_t>& inside, int n) {
  Mask mask;
  mask.frame.size = {n, n, n};  // unit spacing: distances in voxels
  mask.inside = inside;
  return signed_distance(mask).phi;
}

namespace {

// The moving distance and its gradient (central differences; one-sided at the edges), together
// so one trilinear gather reads all four.
std::vector<std::array<float, 4>> with_gradient(const std::vector<float>& phi, int n) {
  std::vector<std::array<float, 4>> out(phi.size());
  const std::array<int64_t, 3> stride{1, n, int64_t{n} * n};
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const int64_t i = x + n * (y + int64_t{n} * z);
        const std::array<int, 3> at{x, y, z};
        out[static_cast<size_t>(i)][0] = phi[static_cast<size_t>(i)];
        for (int a = 0; a < 3; ++a) {
          const int64_t s = stride[static_cast<size_t>(a)];
          const int c = at[static_cast<size_t>(a)];
          const int64_t lo = c > 0 ? i - s : i, hi = c < n - 1 ? i + s : i;
          const float h = static_cast<float>((c < n - 1 ? 1 : 0) + (c > 0 ? 1 : 0));
          out[static_cast<size_t>(i)][static_cast<size_t>(a + 1)] =
              (phi[static_cast<size_t>(hi)] - phi[static_cast<size_t>(lo)]) / std::max(h, 1.0F);
        }
      }
  return out;
}

// The four values at continuous position p (voxels), clamped to the grid.
std::array<float, 4> sample(const std::vector<std::array<float, 4>>& m, int n, float px, float py,
                            float pz) {
  const float top = static_cast<float>(n - 1);
  const float p[3] = {std::clamp(px, 0.0F, top), std::clamp(py, 0.0F, top),
                      std::clamp(pz, 0.0F, top)};
  int c[3];
  float t[3];
  for (int a = 0; a < 3; ++a) {
    c[a] = std::min(static_cast<int>(p[a]), n - 2);
    t[a] = p[a] - static_cast<float>(c[a]);
  }
  std::array<float, 4> out{};
  for (int dz = 0; dz < 2; ++dz)
    for (int dy = 0; dy < 2; ++dy)
      for (int dx = 0; dx < 2; ++dx) {
        const float w = (dx ? t[0] : 1 - t[0]) * (dy ? t[1] : 1 - t[1]) * (dz ? t[2] : 1 - t[2]);
        const auto& v =
            m[static_cast<size_t>(c[0] + dx + n * (c[1] + dy + int64_t{n} * (c[2] + dz)))];
        for (int k = 0; k < 4; ++k) out[static_cast<size_t>(k)] += w * v[static_cast<size_t>(k)];
      }
  return out;
}

// The demons' step at one point from the fixed value and the moving value and gradient there:
// the difference along the gradient, damped by the difference itself where the gradient is
// small (Thirion's normalisation); `cap` bounds the difference (0: none).
void add_demons_step(float fixed, const std::array<float, 4>& v, float cap, float weight,
                     std::array<float, 3>& step) {
  const float diff = cap > 0.0F ? std::clamp(fixed - v[0], -cap, cap) : fixed - v[0];
  const float g2 = v[1] * v[1] + v[2] * v[2] + v[3] * v[3];
  const float s = weight * diff / (g2 + diff * diff + 1e-3F);
  for (int a = 0; a < 3; ++a) step[static_cast<size_t>(a)] += s * v[static_cast<size_t>(a + 1)];
}

// Both registrations (without densities: the outline alone).
Displacement demons(const std::vector<float>& fixed, const std::vector<float>& moving,
                    const std::vector<float>* fixed_density,
                    const std::vector<float>* moving_density, int n,
                    const RegisterOutlinesOptions& options) {
  const auto m = with_gradient(moving, n);
  const bool densities = fixed_density != nullptr && options.density_iterations > 0;
  const auto md = densities ? with_gradient(*moving_density, n) : decltype(m){};
  const std::vector<float> kernel = gaussian_kernel(options.smooth_voxels);
  const std::array<int64_t, 3> size{n, n, n};
  const float band = static_cast<float>(options.band_voxels);
  const float depth = static_cast<float>(options.density_depth_voxels);
  const float weight = static_cast<float>(options.density_weight);
  Displacement d;
  for (auto& u : d.u) u.assign(fixed.size(), 0.0F);
  // The points pushed: those near the organ's outline (the moving outline is pulled to it);
  // with densities, in their steps, also those inside it (flagged: `deep`).
  struct Point {
    int x, y, z;
    bool near, deep;
  };
  std::vector<Point> points;
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const float f = fixed[static_cast<size_t>(x + n * (y + int64_t{n} * z))];
        const bool near = std::abs(f) < band, deep = densities && f < -depth;
        if (near || deep) points.push_back({x, y, z, near, deep});
      }
  std::vector<float> scratch;
  const int steps = options.iterations + (densities ? options.density_iterations : 0);
  for (int it = 0; it < steps; ++it) {
    const bool inner = it >= options.iterations;
    for (const Point& p : points) {
      if (!p.near && !inner) continue;
      const size_t i = static_cast<size_t>(p.x + n * (p.y + int64_t{n} * p.z));
      const float px = static_cast<float>(p.x) + d.u[0][i],
                  py = static_cast<float>(p.y) + d.u[1][i],
                  pz = static_cast<float>(p.z) + d.u[2][i];
      std::array<float, 3> step{};
      // The outline's difference capped at 3 voxels: far from it the distances say little.
      if (p.near) add_demons_step(fixed[i], sample(m, n, px, py, pz), 3.0F, 1.0F, step);
      if (inner && p.deep)
        add_demons_step((*fixed_density)[i], sample(md, n, px, py, pz), 0.0F, weight, step);
      for (int a = 0; a < 3; ++a) d.u[static_cast<size_t>(a)][i] += step[static_cast<size_t>(a)];
    }
    for (auto& u : d.u) smooth_grid(u, size, kernel, scratch);
  }
  return d;
}

}  // namespace

Displacement register_outlines(const std::vector<float>& fixed, const std::vector<float>& moving,
                               int n, const RegisterOutlinesOptions& options) {
  return demons(fixed, moving, nullptr, nullptr, n, options);
}

Displacement register_outlines_and_densities(const std::vector<float>& fixed,
                                             const std::vector<float>& moving,
                                             const std::vector<float>& fixed_density,
                                             const std::vector<float>& moving_density, int n,
                                             const RegisterOutlinesOptions& options) {
  return demons(fixed, moving, &fixed_density, &moving_density, n, options);
}

std::vector<uint8_t> warp_labels(const std::vector<uint8_t>& moving, const Displacement& d, int n) {
  std::vector<uint8_t> out(moving.size(), 0);
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const size_t i = static_cast<size_t>(x + n * (y + int64_t{n} * z));
        const long sx = std::lround(x + d.u[0][i]), sy = std::lround(y + d.u[1][i]),
                   sz = std::lround(z + d.u[2][i]);
        if (sx < 0 || sy < 0 || sz < 0 || sx >= n || sy >= n || sz >= n) continue;
        out[i] = moving[static_cast<size_t>(sx + n * (sy + int64_t{n} * sz))];
      }
  return out;
}

}  // namespace lamina::geometry::detail
