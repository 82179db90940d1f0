// The hand-written exact distance transform against brute force: every voxel's distance to the
// nearest voxel inside, and (the feature transform) which voxel that is, on random masks of
// anisotropic grids, and the edge cases.
#include "distance_transform.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace {

using namespace lamina;

// A small anisotropic grid, and random masks of it, sparse to half full, each with a voxel
// inside.
GridFrame small_grid() {
  GridFrame f;
  f.size = {17, 11, 9};
  f.spacing_mm = {0.7, 1.3, 2.5};
  return f;
}
struct RandomMask {
  double fill;
  std::vector<uint8_t> mask;
};
std::vector<RandomMask> random_masks(const GridFrame& f, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<RandomMask> out;
  for (const double fill : {0.002, 0.05, 0.5}) {
    std::bernoulli_distribution in(fill);
    std::vector<uint8_t> mask(static_cast<size_t>(f.voxel_count()));
    for (auto& m : mask) m = in(rng);
    mask[37] = 1;  // at least one
    out.push_back({fill, std::move(mask)});
  }
  return out;
}

TEST(DistanceTransform, IsTheNearestInsideVoxelsDistanceExactly) {
  const GridFrame f = small_grid();
  for (const auto& [fill, mask] : random_masks(f, 11)) {
    const std::vector<float> d = geometry::detail::distance_to_foreground(f, mask);
    for (int64_t k = 0; k < f.size[2]; ++k)
      for (int64_t j = 0; j < f.size[1]; ++j)
        for (int64_t i = 0; i < f.size[0]; ++i) {
          double best = std::numeric_limits<double>::infinity();
          for (int64_t c = 0; c < f.size[2]; ++c)
            for (int64_t b = 0; b < f.size[1]; ++b)
              for (int64_t a = 0; a < f.size[0]; ++a)
                if (mask[static_cast<size_t>(f.index(a, b, c))])
                  best = std::min(best, std::hypot((a - i) * 0.7, (b - j) * 1.3, (c - k) * 2.5));
          ASSERT_NEAR(d[static_cast<size_t>(f.index(i, j, k))], best, 1e-5 * (1.0 + best))
              << i << " " << j << " " << k << " fill " << fill;
        }
  }
}

TEST(DistanceTransform, NothingInsideIsInfinitelyFar) {
  GridFrame f;
  f.size = {4, 3, 2};
  const std::vector<float> d =
      geometry::detail::distance_to_foreground(f, std::vector<uint8_t>(24, 0));
  for (const float x : d) EXPECT_EQ(x, std::numeric_limits<float>::infinity());
}

TEST(NearestForeground, IsANearestInsideVoxelExactly) {
  const GridFrame f = small_grid();
  for (const auto& [fill, mask] : random_masks(f, 17)) {
    const std::vector<int64_t> near = geometry::detail::nearest_foreground(f, mask);
    const auto sq = [&](int64_t a, int64_t b) {
      double s = 0.0;
      const int64_t ia[3] = {a % f.size[0], (a / f.size[0]) % f.size[1],
                             a / (f.size[0] * f.size[1])};
      const int64_t ib[3] = {b % f.size[0], (b / f.size[0]) % f.size[1],
                             b / (f.size[0] * f.size[1])};
      for (int c = 0; c < 3; ++c) {
        const double d = static_cast<double>(ia[c] - ib[c]) * f.spacing_mm[c];
        s += d * d;
      }
      return s;
    };
    for (int64_t v = 0; v < f.voxel_count(); ++v) {
      const int64_t got = near[static_cast<size_t>(v)];
      ASSERT_GE(got, 0);
      ASSERT_NE(mask[static_cast<size_t>(got)], 0) << "not inside";
      if (mask[static_cast<size_t>(v)] != 0) EXPECT_EQ(got, v) << "an inside voxel is its own";
      double best = std::numeric_limits<double>::infinity();
      for (int64_t w = 0; w < f.voxel_count(); ++w)
        if (mask[static_cast<size_t>(w)] != 0) best = std::min(best, sq(v, w));
      EXPECT_NEAR(sq(v, got), best, 1e-9 * (1.0 + best)) << "voxel " << v << " fill " << fill;
    }
  }
}

TEST(NearestForeground, NothingInsideHasNoNearest) {
  GridFrame f;
  f.size = {4, 3, 2};
  for (const int64_t x : geometry::detail::nearest_foreground(f, std::vector<uint8_t>(24, 0)))
    EXPECT_EQ(x, -1);
}

}  // namespace
