#include "lamina/io/label_volume_io.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "lamina/core/error.h"
#include "lamina/core/grid.h"
#include "support/temp_dir.h"
#include "support/test_paths.h"

namespace lamina::io {
namespace {

using lamina::test::TempDir;

namespace fs = std::filesystem;

// An anisotropic, rotated, off-origin grid: a reader or writer that drops, swaps or transposes
// any part of the frame fails the round trip. The origin is exactly representable in float,
// since NIfTI stores it in single precision.
LabelVolume make_volume(const std::vector<int32_t>& palette) {
  LabelVolume v;
  v.frame.size = {7, 5, 4};
  v.frame.spacing_mm = {0.7, 0.9, 1.6};
  v.frame.origin_mm = {-120.25, 35.5, 7.125};
  // 30 degrees about z: not symmetric, so a transposed matrix is caught.
  const double c = std::sqrt(3.0) / 2.0, s = 0.5;
  v.frame.direction = {c, -s, 0, s, c, 0, 0, 0, 1};
  v.labels.resize(static_cast<size_t>(v.frame.voxel_count()));
  // Position-dependent labels, so a permuted or flipped axis changes the data.
  for (int64_t k = 0; k < v.frame.size[2]; ++k)
    for (int64_t j = 0; j < v.frame.size[1]; ++j)
      for (int64_t i = 0; i < v.frame.size[0]; ++i)
        v.labels[v.frame.index(i, j, k)] =
            palette[static_cast<size_t>((i + 2 * j + 3 * k) % std::ssize(palette))];
  return v;
}

void expect_same_frame(const GridFrame& a, const GridFrame& b, double tol) {
  EXPECT_EQ(a.size, b.size);
  for (int n = 0; n < 3; ++n) {
    EXPECT_NEAR(a.spacing_mm[n], b.spacing_mm[n], tol) << "spacing " << n;
    EXPECT_NEAR(a.origin_mm[n], b.origin_mm[n], tol) << "origin " << n;
  }
  for (int n = 0; n < 9; ++n) EXPECT_NEAR(a.direction[n], b.direction[n], tol) << "direction " << n;
}

bool has_hidden_file(const fs::path& dir) {
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().starts_with(".")) return true;
  return false;
}

class RoundTrip : public ::testing::TestWithParam<std::string> {};

TEST_P(RoundTrip, SmallLabelsKeepLabelsAndFrame) {
  TempDir dir;
  const LabelVolume v = make_volume({0, 1, 2});
  const std::string path = dir.file("labels" + GetParam());
  write_label_volume(v, path);
  const LabelVolume r = read_label_volume(path);
  expect_same_frame(r.frame, v.frame, 1e-6);
  EXPECT_EQ(r.labels, v.labels);
  EXPECT_EQ(r.source, path);
  EXPECT_FALSE(has_hidden_file(dir.path)) << "the temporary file was left behind";
}

// Labels outside 0..255 take the int32 path; values beyond int16 and below zero make sure that
// no narrower type is used on the way.
TEST_P(RoundTrip, WideLabelsKeepLabelsAndFrame) {
  TempDir dir;
  const LabelVolume v = make_volume({0, 300, 70000, -3, 1});
  const std::string path = dir.file("wide" + GetParam());
  write_label_volume(v, path);
  const LabelVolume r = read_label_volume(path);
  expect_same_frame(r.frame, v.frame, 1e-6);
  EXPECT_EQ(r.labels, v.labels);
}

INSTANTIATE_TEST_SUITE_P(Formats, RoundTrip,
                         ::testing::Values(".nii", ".nii.gz", ".nrrd", ".seg.nrrd", ".mha", ".mhd"),
                         [](const auto& info) {
                           std::string name = info.param.substr(1);
                           std::replace(name.begin(), name.end(), '.', '_');
                           return name;
                         });

// The documented storage type: uint8 when every label fits, else int32. An uncompressed NIfTI-1
// file is its 352-byte header followed by the voxels, so its size shows the type.
TEST(WriteLabelVolume, StoresUint8WhenLabelsFitElseInt32) {
  TempDir dir;
  const LabelVolume small = make_volume({0, 1, 255});
  const LabelVolume wide = make_volume({0, 1, 256});
  const auto voxels = static_cast<uintmax_t>(small.frame.voxel_count());
  write_label_volume(small, dir.file("small.nii"));
  write_label_volume(wide, dir.file("wide.nii"));
  EXPECT_EQ(fs::file_size(dir.file("small.nii")), 352 + voxels);
  EXPECT_EQ(fs::file_size(dir.file("wide.nii")), 352 + 4 * voxels);
}

TEST(WriteLabelVolume, MissingFolderIsAnOutputError) {
  TempDir dir;
  const std::string path = dir.file("no/such/folder/out.nii.gz");
  try {
    write_label_volume(make_volume({0, 1}), path);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::kOutput);
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(path));
}

// ---------------------------------------------------------------------------------------------
// The real masks of tests/data, against the numbers in tests/data/PROVENANCE.md.

struct RealMask {
  std::string file;
  std::array<int64_t, 3> size;
  double spacing_mm;
  std::array<double, 3> nifti_origin_ras;  ///< as PROVENANCE gives it (the NIfTI affine, RAS)
  double origin_tol_mm;                    ///< PROVENANCE rounds to this
  int64_t voxels;
  std::array<int64_t, 3> bbox_lo, bbox_hi;  ///< index bounding box; {-1,...} = not documented
};

class RealData : public ::testing::TestWithParam<RealMask> {};

TEST_P(RealData, MatchesProvenance) {
  const RealMask& m = GetParam();
  const LabelVolume v = read_label_volume(test::real_data(m.file));
  EXPECT_EQ(v.frame.size, m.size);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(v.frame.spacing_mm[a], m.spacing_mm, 1e-6);
  // ITK reports patient LPS: a positive-diagonal RAS affine becomes direction diag(-1, -1, 1)
  // with the first two origin coordinates negated.
  const std::array<double, 9> lps{-1, 0, 0, 0, -1, 0, 0, 0, 1};
  for (int n = 0; n < 9; ++n) EXPECT_NEAR(v.frame.direction[n], lps[n], 1e-6) << n;
  EXPECT_NEAR(v.frame.origin_mm[0], -m.nifti_origin_ras[0], m.origin_tol_mm);
  EXPECT_NEAR(v.frame.origin_mm[1], -m.nifti_origin_ras[1], m.origin_tol_mm);
  EXPECT_NEAR(v.frame.origin_mm[2], m.nifti_origin_ras[2], m.origin_tol_mm);

  ASSERT_EQ(std::ssize(v.labels), v.frame.voxel_count());
  const std::set<int32_t> values(v.labels.begin(), v.labels.end());
  EXPECT_EQ(values, (std::set<int32_t>{0, 1}));
  EXPECT_EQ(std::count(v.labels.begin(), v.labels.end(), 1), m.voxels);

  if (m.bbox_lo[0] < 0) return;
  std::array<int64_t, 3> lo{v.frame.size}, hi{-1, -1, -1};
  for (int64_t k = 0; k < v.frame.size[2]; ++k)
    for (int64_t j = 0; j < v.frame.size[1]; ++j)
      for (int64_t i = 0; i < v.frame.size[0]; ++i)
        if (v.labels[v.frame.index(i, j, k)] != 0) {
          const std::array<int64_t, 3> p{i, j, k};
          for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
        }
  // Index order matters: a reader that permuted or flipped axes would move the box.
  EXPECT_EQ(lo, m.bbox_lo);
  EXPECT_EQ(hi, m.bbox_hi);
}

INSTANTIATE_TEST_SUITE_P(Masks, RealData,
                         ::testing::Values(RealMask{"liver_sofa_smooth_voxelized_1mm.nii.gz",
                                                    {72, 57, 52},
                                                    1.0,
                                                    {-50, -1, -20},
                                                    1e-6,
                                                    39284,
                                                    {-1, -1, -1},
                                                    {-1, -1, -1}},
                                           RealMask{"liver_totalseg_example_3mm.nii.gz",
                                                    {122, 101, 112},
                                                    3.0,
                                                    {-177.956, 11.319, 94.302},
                                                    1e-3,
                                                    41602,
                                                    {36, 25, 70},
                                                    {105, 86, 111}},
                                           RealMask{"kidney_right_totalseg_example_3mm.nii.gz",
                                                    {122, 101, 112},
                                                    3.0,
                                                    {-177.956, 11.319, 94.302},
                                                    1e-3,
                                                    6993,
                                                    {70, 29, 66},
                                                    {93, 54, 101}}),
                         [](const auto& info) {
                           const std::string& f = info.param.file;
                           std::string name = f.substr(0, f.find('.'));
                           return name;
                         });

}  // namespace
}  // namespace lamina::io
