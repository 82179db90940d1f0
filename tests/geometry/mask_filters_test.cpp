#include "lamina/geometry/mask_filters.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "lamina/geometry/extract_isosurface.h"
#include "lamina/geometry/mesh_measures.h"
#include "lamina/geometry/prepare_mask.h"
#include "support/volumes.h"

namespace {

using namespace lamina;

Mask sphere_mask(double radius, double spacing, int64_t n) {
  LabelVolume v = test::empty_volume(n, spacing);
  const double mid = static_cast<double>(n - 1) / 2.0;
  test::paint_sphere(v, v.frame.to_physical(mid, mid, mid), radius, 1);
  return geometry::prepare_mask(v, {.pad_voxels = 2}).mask;
}

TEST(SignedDistance, SphereDepthAndZeroLevelVolume) {
  const double r = 12.0;
  const Mask m = sphere_mask(r, 1.0, 33);  // odd: the centre is a voxel centre
  int64_t voxels = 0;
  for (uint8_t b : m.inside) voxels += b;
  const DistanceField d = geometry::signed_distance(m);
  // Deepest point is the centre, about r inside.
  const float deepest = *std::min_element(d.phi.begin(), d.phi.end());
  EXPECT_NEAR(-deepest, r, 1.0);
  // Negative inside, positive outside, everywhere.
  for (size_t v = 0; v < d.phi.size(); ++v) ASSERT_EQ(d.phi[v] < 0.0f, m.inside[v] == 1) << v;
  // The zero isosurface encloses the voxel volume (the half-voxel shift puts it on the faces).
  const SurfaceMesh s = geometry::extract_isosurface(d, 0.0);
  const double vol = geometry::measure_mesh(s).volume_mm3;
  EXPECT_NEAR(vol / static_cast<double>(voxels), 1.0, 0.015);
  // An isosurface 5 mm inside is a sphere of radius r - 5, to within half a voxel: where exactly
  // a voxelised sphere's surface lies is uncertain by that much.
  const SurfaceMesh inner = geometry::extract_isosurface(d, -5.0);
  const double radius =
      std::cbrt(3.0 * geometry::measure_mesh(inner).volume_mm3 / (4.0 * std::numbers::pi));
  EXPECT_NEAR(radius, r - 5.0, 0.5);
}

TEST(SignedDistance, UsesPhysicalSpacing) {
  // Same physical sphere at 0.5 mm: the depth is in mm, not voxels.
  const Mask m = sphere_mask(6.0, 0.5, 33);
  const DistanceField d = geometry::signed_distance(m);
  EXPECT_NEAR(-*std::min_element(d.phi.begin(), d.phi.end()), 6.0, 0.5);
}

TEST(DownsampleMask, KeepsVolumeAndExtent) {
  const Mask m = sphere_mask(12.0, 0.5, 56);
  const Mask c = geometry::downsample_mask(m, {2, 2, 2});
  EXPECT_EQ(c.frame.spacing_mm[0], 1.0);
  int64_t fine = 0, coarse = 0;
  for (uint8_t b : m.inside) fine += b;
  for (uint8_t b : c.inside) coarse += b;
  EXPECT_NEAR(static_cast<double>(coarse) * 1.0 / (static_cast<double>(fine) * 0.125), 1.0, 0.03);
  // The coarse grid covers the same place: its first voxel centre is the centre of the first
  // 2x2x2 block of fine voxels.
  const auto a = m.frame.to_physical(0.5, 0.5, 0.5);
  const auto b = c.frame.to_physical(0, 0, 0);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(a[k], b[k], 1e-6);
}

TEST(Components, KeepLargestAndFillCavities) {
  Mask m;
  m.frame.size = {10, 10, 10};
  m.inside.assign(1000, 0);
  auto set = [&](int i, int j, int k) { m.inside[m.frame.index(i, j, k)] = 1; };
  for (int k = 2; k < 7; ++k)
    for (int j = 2; j < 7; ++j)
      for (int i = 2; i < 7; ++i)
        if (!(i == 4 && j == 4 && k == 4)) set(i, j, k);  // a 5^3 cube with a 1-voxel hole
  set(8, 8, 8);                                           // a lone voxel
  set(7, 7, 7);                                           // touches the cube only diagonally
  const geometry::ComponentStats s = geometry::keep_largest_component(m);
  EXPECT_EQ(s.components, 3);  // face connectivity: the diagonal voxel is separate
  EXPECT_EQ(s.kept_voxels, 124);
  EXPECT_EQ(s.dropped_voxels, 2);
  EXPECT_EQ(geometry::fill_cavities(m), 1);
}

}  // namespace
