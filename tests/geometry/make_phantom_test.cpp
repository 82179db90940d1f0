#include "lamina/geometry/make_phantom.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace {

using lamina::geometry::make_phantom;
using lamina::geometry::phantom_implicit;

double inside_volume_ml(const lamina::LabelVolume& v) {
  int64_t n = 0;
  for (int32_t l : v.labels) n += l != 0;
  return static_cast<double>(n) * v.frame.voxel_volume_mm3() / 1000.0;
}

TEST(Phantom, AdultLiverSizedAndAwayFromTheBorder) {
  const lamina::LabelVolume v = make_phantom({.spacing_mm = {2.0, 2.0, 2.0}});
  // An adult liver is 1.2-1.9 L; the phantom must be in that range.
  EXPECT_GT(inside_volume_ml(v), 1200.0);
  EXPECT_LT(inside_volume_ml(v), 1900.0);
  // The default grid leaves background all around the organ.
  const auto& f = v.frame;
  for (int64_t k = 0; k < f.size[2]; ++k)
    for (int64_t j = 0; j < f.size[1]; ++j)
      for (int64_t i = 0; i < f.size[0]; ++i) {
        const bool border = i == 0 || j == 0 || k == 0 || i == f.size[0] - 1 ||
                            j == f.size[1] - 1 || k == f.size[2] - 1;
        if (border) ASSERT_EQ(v.labels[f.index(i, j, k)], 0) << i << " " << j << " " << k;
      }
}

// Lowest inside point along a vertical line (the visceral surface), or NaN if none.
double underside_z(double x, double y) {
  for (double z = -80; z < 85; z += 0.5)
    if (phantom_implicit(x, y, z) < 0) return z;
  return std::numeric_limits<double>::quiet_NaN();
}

TEST(Phantom, HasAConcaveUnderside) {
  // The visceral surface is scooped out: along a line across the organ its height in the middle
  // lies above the chord between the two sides, which no convex shape (a sphere, an ellipsoid)
  // can do.
  const double y = 22.0;
  const double left = underside_z(-90.0, y), mid = underside_z(-50.0, y),
               right = underside_z(-10.0, y);
  ASSERT_FALSE(std::isnan(left) || std::isnan(mid) || std::isnan(right));
  EXPECT_GT(mid, 0.5 * (left + right) + 10.0);
}

TEST(Phantom, HasTwoLobes) {
  // The right lobe is much thicker (superior-inferior extent) than the left one.
  auto thickness = [](double x) {
    int n = 0;
    for (double z = -80; z < 85; z += 1) n += phantom_implicit(x, -10.0, z) < 0;
    return n;
  };
  EXPECT_GT(thickness(-45.0), 2 * thickness(80.0));
  EXPECT_GT(thickness(80.0), 0);
}

TEST(Phantom, SmallGridCropsTheOrganAtTheEdge) {
  const lamina::LabelVolume v = make_phantom({.spacing_mm = {3, 3, 3}, .size = {40, 40, 40}});
  const auto& f = v.frame;
  // 40 voxels of 3 mm = 120 mm, narrower than the 235 mm organ: it reaches the x faces.
  int64_t on_border = 0;
  for (int64_t k = 0; k < f.size[2]; ++k)
    for (int64_t j = 0; j < f.size[1]; ++j)
      on_border +=
          (v.labels[f.index(0, j, k)] != 0) + (v.labels[f.index(f.size[0] - 1, j, k)] != 0);
  EXPECT_GT(on_border, 0);
}

TEST(Phantom, RejectsBadSpacing) {
  EXPECT_THROW(make_phantom({.spacing_mm = {0.0, 1.0, 1.0}}), std::exception);
  EXPECT_THROW(make_phantom({.spacing_mm = {-1.0, 1.0, 1.0}}), std::exception);
}

}  // namespace
