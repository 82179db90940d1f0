// A plane through a tetrahedral volume (src/geometry/volume_by_plane.cpp): each of the three
// ways a plane divides a tetrahedron against its integral, a cube's parts against sampling,
// and a bad plane refused.
#include "lamina/geometry/volume_by_plane.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <random>

#include "lamina/core/error.h"
#include "lamina/core/grid.h"

namespace {

using namespace lamina;

// The unit cube as six tetrahedra about its diagonal (Kuhn's triangulation); corner k at
// (k & 1, k >> 1 & 1, k >> 2 & 1).
void unit_cube(Eigen::MatrixX3d& X, Eigen::MatrixX4i& T) {
  X.resize(8, 3);
  for (int k = 0; k < 8; ++k) X.row(k) << (k & 1), (k >> 1 & 1), (k >> 2 & 1);
  std::array<int, 3> axes{0, 1, 2};
  T.resize(6, 4);
  int t = 0;
  do {
    const int a = 1 << axes[0], b = a | 1 << axes[1];
    T.row(t++) << 0, a, b, 7;
  } while (std::next_permutation(axes.begin(), axes.end()));
}

TEST(VolumeByPlane, EachWayAPlaneDividesATetrahedronMatchesItsIntegral) {
  Eigen::MatrixX3d X(4, 3);
  X << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  Eigen::MatrixX4i T(1, 4);
  T << 0, 1, 2, 3;
  const Eigen::Vector3d half(0.5, 0.0, 0.0);
  // One corner in front (x > 0.5): the corner tetrahedron at half scale, 1/48.
  geometry::PlaneSides s = geometry::volume_by_plane(X, T, half, Eigen::Vector3d(2, 0, 0));
  EXPECT_NEAR(s.front_mm3, 1.0 / 48.0, 1e-15);
  EXPECT_NEAR(s.back_mm3, 1.0 / 6.0 - 1.0 / 48.0, 1e-15);
  // Three corners in front: the same plane facing the other way.
  s = geometry::volume_by_plane(X, T, half, Eigen::Vector3d(-1, 0, 0));
  EXPECT_NEAR(s.front_mm3, 1.0 / 6.0 - 1.0 / 48.0, 1e-15);
  // Two corners each side (x + y > 0.5): integral of s (1 - s) over s in [0.5, 1], 1/12.
  s = geometry::volume_by_plane(X, T, Eigen::Vector3d(0.25, 0.25, 0.0), Eigen::Vector3d(1, 1, 0));
  EXPECT_NEAR(s.front_mm3, 1.0 / 12.0, 1e-15);
  EXPECT_NEAR(s.back_mm3, 1.0 / 12.0, 1e-15);
  // A plane past the tetrahedron: all of it on one side.
  s = geometry::volume_by_plane(X, T, Eigen::Vector3d(0, 0, 5), Eigen::Vector3d(0, 0, 1));
  EXPECT_EQ(s.front_mm3, 0.0);
  EXPECT_NEAR(s.back_mm3, 1.0 / 6.0, 1e-15);
}

TEST(VolumeByPlane, ACubesPartsMatchSamplingForAnyPlane) {
  Eigen::MatrixX3d X;
  Eigen::MatrixX4i T;
  unit_cube(X, T);
  // Through the centre across the diagonal: half each, by symmetry.
  geometry::PlaneSides s =
      geometry::volume_by_plane(X, T, Eigen::Vector3d(0.5, 0.5, 0.5), Eigen::Vector3d(1, 1, 1));
  EXPECT_NEAR(s.front_mm3, 0.5, 1e-14);
  EXPECT_NEAR(s.back_mm3, 0.5, 1e-14);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0), w(-1.0, 1.0);
  std::vector<Eigen::Vector3d> samples(400000);
  for (Eigen::Vector3d& q : samples) q = Eigen::Vector3d(u(rng), u(rng), u(rng));
  for (int trial = 0; trial < 8; ++trial) {
    const Eigen::Vector3d point(u(rng), u(rng), u(rng)), normal(w(rng), w(rng), w(rng));
    s = geometry::volume_by_plane(X, T, point, normal);
    EXPECT_NEAR(s.front_mm3 + s.back_mm3, 1.0, 1e-13);
    const auto in_front = std::count_if(samples.begin(), samples.end(), [&](const auto& q) {
      return (q - point).dot(normal) > 0.0;
    });
    // Sampling's standard error is at most 0.5 / sqrt(400,000) = 0.0008.
    EXPECT_NEAR(s.front_mm3, static_cast<double>(in_front) / samples.size(), 0.004)
        << "plane " << trial;
    // The other way round, the other side.
    const geometry::PlaneSides flipped = geometry::volume_by_plane(X, T, point, -normal);
    EXPECT_NEAR(flipped.front_mm3, s.back_mm3, 1e-13);
  }
}

TEST(VolumeByPlane, VoxelsAreCountedByTheirCentresInPhysicalSpace) {
  // An oblique grid (axes swapped and one reversed, anisotropic spacing, off origin) with two
  // labels: the count on each side against each centre placed by GridFrame::to_physical.
  LabelVolume v;
  v.frame.size = {12, 9, 7};
  v.frame.spacing_mm = {0.8, 1.5, 2.5};
  v.frame.origin_mm = {-4.0, 10.0, 3.0};
  v.frame.direction = {0, -1, 0, 1, 0, 0, 0, 0, 1};
  v.labels.assign(static_cast<size_t>(v.frame.voxel_count()), 0);
  for (int64_t k = 1; k < 6; ++k)
    for (int64_t j = 2; j < 8; ++j)
      for (int64_t i = 1; i < 11; ++i) v.labels[v.frame.index(i, j, k)] = i < 6 ? 1 : 2;
  const Eigen::Vector3d point(-10.7, 14.1, 10.2), normal(0.3, -1.0, 0.4);  // mid-region
  for (const int32_t label : {0, 1, 2}) {
    int64_t front = 0, back = 0;
    for (int64_t k = 0; k < 7; ++k)
      for (int64_t j = 0; j < 9; ++j)
        for (int64_t i = 0; i < 12; ++i) {
          const int32_t l = v.labels[v.frame.index(i, j, k)];
          if (label == 0 ? l <= 0 : l != label) continue;
          const auto c = v.frame.to_physical(static_cast<double>(i), static_cast<double>(j),
                                             static_cast<double>(k));
          ((Eigen::Vector3d(c[0], c[1], c[2]) - point).dot(normal) > 0.0 ? front : back) += 1;
        }
    ASSERT_GT(front, 0) << "the plane must divide label " << label;
    ASSERT_GT(back, 0) << "the plane must divide label " << label;
    const geometry::PlaneSides s = geometry::voxel_volume_by_plane(v, label, point, normal);
    const double voxel = 0.8 * 1.5 * 2.5;
    EXPECT_NEAR(s.front_mm3, static_cast<double>(front) * voxel, 1e-9) << "label " << label;
    EXPECT_NEAR(s.back_mm3, static_cast<double>(back) * voxel, 1e-9) << "label " << label;
  }
  EXPECT_THROW(geometry::voxel_volume_by_plane(v, 0, point, Eigen::Vector3d::Zero()), Error);
}

TEST(VolumeByPlane, APlaneWithoutADirectionIsRefused) {
  Eigen::MatrixX3d X;
  Eigen::MatrixX4i T;
  unit_cube(X, T);
  EXPECT_THROW(geometry::volume_by_plane(X, T, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()),
               Error);
  EXPECT_THROW(
      geometry::volume_by_plane(X, T, Eigen::Vector3d(NAN, 0, 0), Eigen::Vector3d(1, 0, 0)), Error);
}

}  // namespace
