// The hand-written exact distance transform against brute force: every voxel's distance to the
// nearest voxel inside, on random masks of anisotropic grids, and the edge cases.
#include "distance_transform.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace {

using namespace lamina;

TEST(DistanceTransform, IsTheNearestInsideVoxelsDistanceExactly) {
  std::mt19937 rng(11);
  for (const double fill : {0.002, 0.05, 0.5}) {
    GridFrame f;
    f.size = {17, 11, 9};
    f.spacing_mm = {0.7, 1.3, 2.5};
    std::bernoulli_distribution in(fill);
    std::vector<uint8_t> mask(static_cast<size_t>(f.voxel_count()));
    for (auto& m : mask) m = in(rng);
    mask[37] = 1;  // at least one
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

}  // namespace
