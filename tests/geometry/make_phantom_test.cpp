#include "lamina/geometry/make_phantom.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "lamina/geometry/mask_filters.h"

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

namespace {

using lamina::geometry::kPhantomLiver;
using lamina::geometry::kPhantomTumour;
using lamina::geometry::kPhantomVessel;

// Calls visit(label of the voxel, label of each of its six face neighbours inside the grid, the
// voxel's i, j, k).
template <class Visit>
void each_face_pair(const lamina::LabelVolume& v, Visit&& visit) {
  const auto& f = v.frame;
  for (int64_t k = 1; k + 1 < f.size[2]; ++k)
    for (int64_t j = 1; j + 1 < f.size[1]; ++j)
      for (int64_t i = 1; i + 1 < f.size[0]; ++i) {
        const int32_t here = v.labels[static_cast<size_t>(f.index(i, j, k))];
        const int64_t n[6][3] = {{i - 1, j, k}, {i + 1, j, k}, {i, j - 1, k},
                                 {i, j + 1, k}, {i, j, k - 1}, {i, j, k + 1}};
        for (const auto& q : n)
          visit(here, v.labels[static_cast<size_t>(f.index(q[0], q[1], q[2]))], i, j, k);
      }
}

TEST(PhantomAnatomy, TheOrganIsUnchangedAndItsVesselsAndTumourLieInside) {
  const lamina::LabelVolume plain = make_phantom({.spacing_mm = {1.5, 1.5, 1.5}});
  const lamina::LabelVolume v = make_phantom({.spacing_mm = {1.5, 1.5, 1.5}, .anatomy = true});
  ASSERT_EQ(v.labels.size(), plain.labels.size());
  int64_t count[4] = {0, 0, 0, 0}, changed = 0;
  for (size_t q = 0; q < v.labels.size(); ++q) {
    ASSERT_GE(v.labels[q], 0);
    ASSERT_LE(v.labels[q], 3);
    ++count[v.labels[q]];
    changed += (v.labels[q] != 0) != (plain.labels[q] != 0);
  }
  EXPECT_EQ(changed, 0) << "the organ is the union of its labels, voxel for voxel";
  const double voxel = v.frame.voxel_volume_mm3();
  const double tumour_mm3 = static_cast<double>(count[kPhantomTumour]) * voxel;
  EXPECT_NEAR(tumour_mm3, 4.0 / 3.0 * M_PI * 15.0 * 15.0 * 15.0, 0.05 * 14137.0);
  const double vessel_ml = static_cast<double>(count[kPhantomVessel]) * voxel / 1000.0;
  EXPECT_GT(vessel_ml, 10.0);
  EXPECT_LT(vessel_ml, 0.05 * static_cast<double>(count[kPhantomLiver]) * voxel / 1000.0);

  // The tumour touches neither the surface nor the tree; the tree leaves the organ only through
  // the hilum on the underside.
  // The hilum: where the trunk's axis crosses the surface (organ frame, mm).
  const double hilum[3] = {-13.2, 19.8, -46.0};
  int64_t tumour_exposed = 0, tumour_on_vessel = 0, vessel_exits = 0, exits_elsewhere = 0;
  each_face_pair(v, [&](int32_t here, int32_t there, int64_t i, int64_t j, int64_t k) {
    if (here == kPhantomTumour)
      tumour_exposed += there == 0, tumour_on_vessel += there == kPhantomVessel;
    if (here == kPhantomVessel && there == 0) {
      ++vessel_exits;
      double d2 = 0.0;
      const int64_t ijk[3] = {i, j, k};
      for (int a = 0; a < 3; ++a) {
        const double p = v.frame.origin_mm[a] + static_cast<double>(ijk[a]) * v.frame.spacing_mm[a];
        d2 += (p - hilum[a]) * (p - hilum[a]);
      }
      exits_elsewhere += d2 > 15.0 * 15.0;
    }
  });
  EXPECT_EQ(tumour_exposed, 0);
  EXPECT_EQ(tumour_on_vessel, 0);
  EXPECT_GT(vessel_exits, 0) << "the trunk enters through the visceral surface";
  EXPECT_EQ(exits_elsewhere, 0) << "the tree leaves the organ only within 15 mm of the hilum";

  // One tree: a single face-connected component.
  lamina::Mask tree;
  tree.frame = v.frame;
  tree.inside.resize(v.labels.size());
  for (size_t q = 0; q < v.labels.size(); ++q) tree.inside[q] = v.labels[q] == kPhantomVessel;
  EXPECT_EQ(lamina::geometry::keep_largest_component(tree).components, 1);
}

}  // namespace
