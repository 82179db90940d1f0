#include "lamina/geometry/prepare_mask.h"

#include <gtest/gtest.h>

#include "lamina/core/error.h"
#include "support/volumes.h"

namespace {

using namespace lamina;

int64_t count_inside(const Mask& m) {
  int64_t n = 0;
  for (uint8_t b : m.inside) n += b;
  return n;
}

TEST(PrepareMask, KeepsLargestComponentAndReportsTheRest) {
  LabelVolume v = test::empty_volume(40);
  const auto c = v.frame.to_physical(12, 20, 20), c2 = v.frame.to_physical(32, 20, 20);
  test::paint_sphere(v, c, 8.0, 1);
  test::paint_sphere(v, c2, 3.0, 1);
  const int64_t small = test::count_label(v, 1);
  test::paint_sphere(v, c2, 3.0, 0);
  const int64_t big = test::count_label(v, 1);
  test::paint_sphere(v, c2, 3.0, 1);
  const geometry::PreparedMask p = geometry::prepare_mask(v);
  EXPECT_EQ(p.report.components, 2);
  EXPECT_EQ(p.report.kept_voxels, big);
  EXPECT_EQ(p.report.dropped_voxels, small - big);
  EXPECT_EQ(count_inside(p.mask), big);
}

TEST(PrepareMask, FillsCavities) {
  LabelVolume v = test::empty_volume(30);
  const auto c = v.frame.to_physical(15, 15, 15);
  test::paint_sphere(v, c, 10.0, 1);
  test::paint_sphere(v, c, 3.0, 0);  // a hollow core
  const int64_t shell = test::count_label(v, 1);
  const geometry::PreparedMask p = geometry::prepare_mask(v);
  EXPECT_GT(p.report.cavity_voxels_filled, 50);
  EXPECT_EQ(count_inside(p.mask), shell + p.report.cavity_voxels_filled);
  EXPECT_EQ(p.report.components, 1);
}

TEST(PrepareMask, OrganTouchingTheScanEdgeGetsABackgroundBorder) {
  LabelVolume v = test::empty_volume(20);
  for (int64_t k = 0; k < 8; ++k)
    for (int64_t j = 5; j < 15; ++j)
      for (int64_t i = 5; i < 15; ++i) v.labels[v.frame.index(i, j, k)] = 1;
  const geometry::PreparedMask p = geometry::prepare_mask(v);
  EXPECT_TRUE(p.report.touches_scan_border);
  const auto& f = p.mask.frame;
  for (int64_t j = 0; j < f.size[1]; ++j)
    for (int64_t i = 0; i < f.size[0]; ++i) EXPECT_EQ(p.mask.inside[f.index(i, j, 0)], 0);
  // The crop keeps physical positions: the first organ voxel (5,5,0) is at the same place.
  const auto a = v.frame.to_physical(5, 5, 0);
  const auto b = f.to_physical(1, 1, 1);
  for (int d = 0; d < 3; ++d) EXPECT_NEAR(a[d], b[d], 1e-9);
}

TEST(PrepareMask, SelectsALabel) {
  LabelVolume v = test::empty_volume(30);
  test::paint_sphere(v, v.frame.to_physical(10, 15, 15), 5.0, 1);
  test::paint_sphere(v, v.frame.to_physical(21, 15, 15), 4.0, 2);
  const geometry::PreparedMask p = geometry::prepare_mask(v, {.label = 2});
  EXPECT_EQ(count_inside(p.mask), test::count_label(v, 2));
  EXPECT_EQ(p.report.components, 1);
}

TEST(PrepareMask, AbsentLabelEmptyMaskAndTinyOrganAreClearErrors) {
  LabelVolume v = test::empty_volume(10);
  v.source = "scan.nii.gz";
  auto message_of = [](const auto& fn) {
    try {
      fn();
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::kInvalidInput);
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message_of([&] { geometry::prepare_mask(v); }).find("empty"), std::string::npos);
  v.labels[v.frame.index(5, 5, 5)] = 1;
  const std::string tiny = message_of([&] { geometry::prepare_mask(v); });
  EXPECT_NE(tiny.find("scan.nii.gz"), std::string::npos);
  EXPECT_NE(tiny.find("1 voxel"), std::string::npos);
  const std::string absent = message_of([&] { geometry::prepare_mask(v, {.label = 7}); });
  EXPECT_NE(absent.find("label 7"), std::string::npos);
  EXPECT_NE(absent.find("present: 1"), std::string::npos);
}

}  // namespace
