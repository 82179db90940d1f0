// The curve skeleton of a mask: the simple-point test on neighbourhoods whose answer is known,
// and skeletons of shapes whose centrelines are known: a cylinder's axis (ends, radius), a
// torus's circle (a closed curve: its hole kept), a T of tubes (one junction, three ends), on
// anisotropic voxels too.
#include "lamina/geometry/skeletonize.h"

#include <gtest/gtest.h>

#include <cmath>
#include <unordered_set>

#include "support/volumes.h"

namespace {

using namespace lamina;
using geometry::is_simple_point;
using geometry::skeletonize;

uint32_t bit(int dx, int dy, int dz) {
  return 1u << ((dx + 1) + 3 * (dy + 1) + 9 * (dz + 1));
}

// Per skeleton voxel, its 26-neighbours in the skeleton.
std::vector<int> neighbour_counts(const geometry::Skeleton& s) {
  const std::unordered_set<int64_t> on(s.voxels.begin(), s.voxels.end());
  const GridFrame& f = s.frame;
  std::vector<int> counts;
  for (const int64_t v : s.voxels) {
    const int64_t i = v % f.size[0], j = (v / f.size[0]) % f.size[1],
                  k = v / (f.size[0] * f.size[1]);
    int n = 0;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          if ((dx | dy | dz) != 0 && on.count(f.index(i + dx, j + dy, k + dz)) != 0) ++n;
    counts.push_back(n);
  }
  return counts;
}

std::array<double, 3> position_mm(const geometry::Skeleton& s, int64_t v) {
  const GridFrame& f = s.frame;
  return {(v % f.size[0]) * f.spacing_mm[0], ((v / f.size[0]) % f.size[1]) * f.spacing_mm[1],
          (v / (f.size[0] * f.size[1])) * f.spacing_mm[2]};
}

TEST(SimplePoint, AFaceOfASolidIsSimpleAPointOfALineOrInsideIsNot) {
  uint32_t half = 0;  // the centre on the flat top of a solid: everything at dz <= 0
  for (int dz = -1; dz <= 0; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) half |= bit(dx, dy, dz);
  EXPECT_TRUE(is_simple_point(half));
  EXPECT_FALSE(is_simple_point(bit(0, 0, 0))) << "isolated: a component of its own";
  EXPECT_FALSE(is_simple_point(bit(-1, 0, 0) | bit(1, 0, 0))) << "a line's middle: it splits";
  EXPECT_TRUE(is_simple_point(bit(1, 0, 0))) << "a line's end";
  EXPECT_FALSE(is_simple_point((1u << 27) - 1)) << "inside: a cavity";
  uint32_t ring = 0;  // the centre of a ring around it in the plane z = 0: removing it makes no
  for (int dy = -1; dy <= 1; ++dy)    // tunnel (it has one already), but the plane's voxels
    for (int dx = -1; dx <= 1; ++dx)  // above and below are background on both sides: a
      if ((dx | dy) != 0) ring |= bit(dx, dy, 0);  // 6-background split in two
  EXPECT_FALSE(is_simple_point(ring));
}

TEST(Skeletonize, ACylinderBecomesItsAxisWithItsRadius) {
  const double r = 5.0;  // voxels of 1 mm; axis along i at j = k = 10
  const Mask m = test::mask_where({50, 21, 21}, {1, 1, 1}, [&](double x, double y, double z) {
    return x >= 5 && x <= 44 && std::hypot(y - 10, z - 10) <= r;
  });
  const geometry::Skeleton s = skeletonize(m);
  ASSERT_FALSE(s.voxels.empty());
  const std::vector<int> n = neighbour_counts(s);
  int ends = 0;
  std::vector<int> on_axis(50, 0);
  for (size_t k = 0; k < n.size(); ++k) {
    EXPECT_GE(n[k], 1);
    EXPECT_LE(n[k], 2) << "a curve: no junction on a cylinder";
    ends += n[k] == 1;
    const auto p = position_mm(s, s.voxels[k]);
    const double off = std::hypot(p[1] - 10, p[2] - 10);
    if (off <= 0.5) on_axis[static_cast<size_t>(p[0])] = 1;
    // Between the caps' medial cones it is the axis. Within a radius of a flat cap the medial
    // axis becomes a sheet reaching the cap's rim, and a curve's end may follow it there (seen at
    // one end: 5 voxels to the rim): the vessel graph's end trimming is the next stage.
    if (p[0] >= 5 + r && p[0] <= 44 - r) EXPECT_LE(off, 1.0) << "on the axis";
    const double into_cone = std::max(0.0, std::max(5 + r - p[0], p[0] - (44 - r)));
    EXPECT_LE(off, into_cone + 1.0) << "on the axis or a cap's medial cone";
  }
  EXPECT_EQ(ends, 2);
  for (int x = 5 + static_cast<int>(r); x <= 44 - static_cast<int>(r); ++x)
    EXPECT_EQ(on_axis[static_cast<size_t>(x)], 1) << "the axis is whole at x = " << x;
  // Mid-length, the distance to the background is the radius (to the nearest outside centre).
  for (size_t k = 0; k < s.voxels.size(); ++k)
    if (std::abs(position_mm(s, s.voxels[k])[0] - 25.0) < 0.5) {
      EXPECT_GT(s.radius_mm[k], r);
      EXPECT_LT(s.radius_mm[k], r + 1.5);
    }
}

TEST(Skeletonize, ATorusKeepsItsHoleAsAClosedCurve) {
  const double big = 12.0, small = 3.5;  // in the plane k = 10, centred at (20, 20)
  const Mask m = test::mask_where({41, 41, 21}, {1, 1, 1}, [&](double x, double y, double z) {
    return std::hypot(std::hypot(x - 20, y - 20) - big, z - 10) <= small;
  });
  const geometry::Skeleton s = skeletonize(m);
  ASSERT_GE(s.voxels.size(), 40u);
  for (const int c : neighbour_counts(s)) EXPECT_EQ(c, 2) << "a closed curve: no ends";
  for (const int64_t v : s.voxels) {
    const auto p = position_mm(s, v);
    EXPECT_NEAR(std::hypot(p[0] - 20, p[1] - 20), big, 1.5);
    EXPECT_NEAR(p[2], 10.0, 1.0);
  }
}

TEST(Skeletonize, ATOfTubesOnAnisotropicVoxelsHasOneJunctionAndThreeEnds) {
  // A trunk along z and a branch along x from its middle; voxels 0.6 x 0.6 x 1.5 mm.
  const std::array<double, 3> h{0.6, 0.6, 1.5};
  const double r = 2.5;
  const Mask m = test::mask_where({80, 30, 40}, h, [&](double x, double y, double z) {
    const bool trunk = z >= 6 && z <= 54 && std::hypot(x - 12, y - 9) <= r;
    const bool branch = x >= 12 && x <= 42 && std::hypot(y - 9, z - 30) <= r;
    return trunk || branch;
  });
  const geometry::Skeleton s = skeletonize(m);
  const std::vector<int> n = neighbour_counts(s);
  int ends = 0, junction = 0;
  for (const int c : n) {
    ends += c == 1;
    junction += c >= 3;
  }
  EXPECT_EQ(ends, 3);
  EXPECT_GE(junction, 1);
  EXPECT_LE(junction, 4) << "one junction, a few voxels at most";
  for (size_t k = 0; k < s.voxels.size(); ++k) {  // on the tubes' axes, radius about r
    const auto p = position_mm(s, s.voxels[k]);
    const double off = std::min(std::hypot(p[0] - 12, p[1] - 9), std::hypot(p[1] - 9, p[2] - 30));
    EXPECT_LT(off, 1.6);
    EXPECT_LT(s.radius_mm[k], r + 1.6);
  }
}

TEST(Skeletonize, AnEmptyMaskHasNoSkeletonAndABallShrinksToAPoint) {
  const Mask empty =
      test::mask_where({8, 8, 8}, {1, 1, 1}, [](double, double, double) { return false; });
  EXPECT_TRUE(skeletonize(empty).voxels.empty());
  const Mask ball = test::mask_where({21, 21, 21}, {1, 1, 1}, [](double x, double y, double z) {
    return std::hypot(x - 10, y - 10, z - 10) <= 6.0;
  });
  const geometry::Skeleton s = skeletonize(ball);
  ASSERT_EQ(s.voxels.size(), 1u) << "a ball has no tunnel or end to keep";
  const auto p = position_mm(s, s.voxels[0]);
  EXPECT_LE(std::hypot(p[0] - 10, p[1] - 10, p[2] - 10), 1.8);
}

}  // namespace
