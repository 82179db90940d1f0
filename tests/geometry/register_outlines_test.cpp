// The atlas's outline registration (src/geometry/register_outlines.h) and the Gaussian smoothing
// it and the atlas's votes use (smooth_grid.h): a shape moved and squashed is carried back onto
// the fixed one without folding, densities line up what lies inside, and the smoothing keeps a
// grid's total and is the Gaussian.
#include "register_outlines.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "smooth_grid.h"

namespace {

using namespace lamina::geometry::detail;

constexpr int kN = 40;
size_t at(int x, int y, int z) {
  return static_cast<size_t>(x + kN * (y + kN * z));
}

// An ellipsoid of semi-axes (a, b, c) voxels about (cx, cy, cz).
std::vector<uint8_t> ellipsoid(double cx, double cy, double cz, double a, double b, double c) {
  std::vector<uint8_t> m(static_cast<size_t>(kN) * kN * kN, 0);
  for (int z = 0; z < kN; ++z)
    for (int y = 0; y < kN; ++y)
      for (int x = 0; x < kN; ++x) {
        const double u = (x - cx) / a, v = (y - cy) / b, w = (z - cz) / c;
        m[at(x, y, z)] = u * u + v * v + w * w <= 1.0 ? 1 : 0;
      }
  return m;
}

double dice(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
  double both = 0, sum = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    both += (a[i] != 0 && b[i] != 0) ? 1 : 0;
    sum += (a[i] != 0) + (b[i] != 0);
  }
  return 2.0 * both / sum;
}

// The least Jacobian determinant of x -> x + u(x) over the interior (central differences).
double least_jacobian(const Displacement& d) {
  double least = 1e9;
  for (int z = 1; z < kN - 1; ++z)
    for (int y = 1; y < kN - 1; ++y)
      for (int x = 1; x < kN - 1; ++x) {
        double j[3][3];
        const int step[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) {
            const auto& s = step[b];
            j[a][b] = (a == b ? 1.0 : 0.0) + 0.5 * (d.u[a][at(x + s[0], y + s[1], z + s[2])] -
                                                    d.u[a][at(x - s[0], y - s[1], z - s[2])]);
          }
        const double det = j[0][0] * (j[1][1] * j[2][2] - j[1][2] * j[2][1]) -
                           j[0][1] * (j[1][0] * j[2][2] - j[1][2] * j[2][0]) +
                           j[0][2] * (j[1][0] * j[2][1] - j[1][1] * j[2][0]);
        least = std::min(least, det);
      }
  return least;
}

TEST(RegisterOutlines, CarriesAMovedAndSquashedShapeOntoTheFixedOneWithoutFolding) {
  const auto fixed = ellipsoid(20, 20, 20, 12, 9, 8);
  const auto moving = ellipsoid(22.5, 18, 21.5, 10, 10.5, 7);  // moved 2-3 voxels, reshaped
  const double before = dice(fixed, moving);
  const Displacement d =
      register_outlines(signed_distance_voxels(fixed, kN), signed_distance_voxels(moving, kN), kN);
  const double after = dice(fixed, warp_labels(moving, d, kN));
  EXPECT_LT(before, 0.80);
  EXPECT_GT(after, 0.95) << "before " << before;
  // The map stays one to one: the displacement's Jacobian determinant (central differences)
  // positive at every interior point.
  EXPECT_GT(least_jacobian(d), 0.0);
}

// A vessel (a rod along z, as a density smoothed by one voxel, over its mean in the shape)
// inside a ball, `x` voxels along x.
std::vector<float> rod_density(const std::vector<uint8_t>& ball, double x) {
  std::vector<float> v(ball.size(), 0.0F);
  for (int z = 0; z < kN; ++z)
    for (int y = 0; y < kN; ++y)
      for (int i = 0; i < kN; ++i) {
        const double r2 = (i - x) * (i - x) + (y - 20.0) * (y - 20.0);
        if (ball[at(i, y, z)] != 0 && r2 <= 1.5 * 1.5) v[at(i, y, z)] = 1.0F;
      }
  std::vector<float> scratch;
  smooth_grid(v, {kN, kN, kN}, gaussian_kernel(1.0), scratch);
  double sum = 0, count = 0;
  for (size_t i = 0; i < v.size(); ++i)
    if (ball[i] != 0) {
      sum += v[i];
      ++count;
    }
  for (float& d : v) d = static_cast<float>(d / (sum / count));
  return v;
}

// Where the moving rod lands in the fixed grid: the mean x of the points the displacement
// carries onto it (the rod's voxels as labels, warped).
double rod_x_after(const std::vector<uint8_t>& ball, double x, const Displacement& d) {
  std::vector<uint8_t> rod(ball.size(), 0);
  for (int z = 0; z < kN; ++z)
    for (int y = 0; y < kN; ++y)
      for (int i = 0; i < kN; ++i)
        rod[at(i, y, z)] =
            ball[at(i, y, z)] != 0 && std::abs(i - x) <= 1.0 && std::abs(y - 20.0) <= 1.0;
  const std::vector<uint8_t> warped = warp_labels(rod, d, kN);
  double sum = 0, count = 0;
  for (int z = 0; z < kN; ++z)
    for (int y = 0; y < kN; ++y)
      for (int i = 0; i < kN; ++i)
        if (warped[at(i, y, z)] != 0) {
          sum += i;
          ++count;
        }
  return count > 0 ? sum / count : -1.0;
}

TEST(RegisterOutlines, TheDensitiesLineUpWhatLiesInsideTheOutline) {
  // The same ball, its vessel 2 voxels left of the centre in the moving one and 2 right in the
  // fixed one: the outlines agree, so the outline alone moves nothing inside; the densities
  // carry the moving vessel onto the fixed one's, the outline kept and the map one to one.
  const auto ball = ellipsoid(20, 20, 20, 14, 14, 14);
  const auto phi = signed_distance_voxels(ball, kN);
  const auto fixed = rod_density(ball, 22.0), moving = rod_density(ball, 18.0);
  const double outline_only = rod_x_after(ball, 18.0, register_outlines(phi, phi, kN));
  const Displacement d = register_outlines_and_densities(phi, phi, fixed, moving, kN);
  const double with_densities = rod_x_after(ball, 18.0, d);
  EXPECT_NEAR(outline_only, 18.0, 0.1);
  EXPECT_NEAR(with_densities, 22.0, 1.0) << "outline only: " << outline_only;  // 21.53 measured
  EXPECT_GT(dice(ball, warp_labels(ball, d, kN)), 0.98);
  EXPECT_GT(least_jacobian(d), 0.0);
}

TEST(RegisterOutlines, LeavesAShapeOnItselfWhereItIs) {
  const auto shape = ellipsoid(19, 21, 20, 11, 8, 9);
  const auto phi = signed_distance_voxels(shape, kN);
  const Displacement d = register_outlines(phi, phi, kN);
  for (const auto& u : d.u)
    for (const float v : u) ASSERT_LT(std::abs(v), 1e-4F);
}

TEST(SmoothGrid, IsTheGaussianAndKeepsTheGridsTotal) {
  const std::array<int64_t, 3> size{13, 9, 11};
  std::vector<float> v(static_cast<size_t>(13 * 9 * 11));
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0F, 1.0F);
  for (float& x : v) x = u(rng);
  const std::vector<float> before = v;
  const double sigma = 1.3;
  const std::vector<float> k = gaussian_kernel(sigma);
  std::vector<float> scratch;
  smooth_grid(v, size, k, scratch);
  double total_before = 0, total_after = 0;
  for (size_t i = 0; i < v.size(); ++i) {
    total_before += before[i];
    total_after += v[i];
  }
  // Mirrored edges hand back what the kernel would carry off the grid: the total stays.
  EXPECT_NEAR(total_after, total_before, 1e-3 * total_before);
  // Points inside and at the corner against the triple sum over the mirrored grid.
  const int r = static_cast<int>(k.size()) / 2;
  const auto mirror = [](int i, int n) {
    while (i < 0 || i >= n) i = i < 0 ? -i - 1 : 2 * n - i - 1;
    return i;
  };
  for (const auto& p : {std::array<int, 3>{6, 4, 5}, std::array<int, 3>{0, 8, 1}}) {
    double want = 0;
    for (int a = -r; a <= r; ++a)
      for (int b = -r; b <= r; ++b)
        for (int c = -r; c <= r; ++c)
          want +=
              double{k[a + r]} * k[b + r] * k[c + r] *
              before[static_cast<size_t>(mirror(p[0] + a, 13) +
                                         13 * (mirror(p[1] + b, 9) + 9 * mirror(p[2] + c, 11)))];
    EXPECT_NEAR(v[static_cast<size_t>(p[0] + 13 * (p[1] + 9 * p[2]))], want, 1e-5);
  }
}

}  // namespace
