// The display skin (geometry/display_skin.h) on the phantom at 1.5 mm: closed, manifold,
// outward, one piece, its triangle budget met, its volume within 1% of the mask's and its mean
// distance to the mask's boundary within half a voxel (issue 33's targets).
#include "lamina/geometry/display_skin.h"

#include <gtest/gtest.h>

#include "lamina/core/error.h"
#include "lamina/geometry/extract_isosurface.h"
#include "lamina/geometry/make_phantom.h"
#include "lamina/geometry/mask_filters.h"
#include "lamina/geometry/mesh_measures.h"
#include "lamina/geometry/prepare_mask.h"
#include "lamina/geometry/remesh.h"
#include "lamina/geometry/smooth_surface.h"
#include "support/volumes.h"

namespace {

using namespace lamina;

TEST(DisplaySkin, IsAClosedOutwardSurfaceOnTheMasksBoundaryWithinItsBudget) {
  const geometry::PreparedMask prepared =
      geometry::prepare_mask(geometry::make_phantom({.spacing_mm = {1.5, 1.5, 1.5}}));
  const SurfaceMesh skin = geometry::display_skin(prepared.mask, 20000);
  const geometry::MeshQuality q = geometry::measure_mesh(skin);
  EXPECT_TRUE(q.closed);
  EXPECT_TRUE(q.manifold);
  EXPECT_TRUE(q.outward);
  EXPECT_EQ(q.components, 1);
  EXPECT_EQ(q.degenerate_faces, 0);
  EXPECT_NEAR(static_cast<double>(q.faces), 20000.0, 0.1 * 20000.0);
  const double mask_mm3 = prepared.report.kept_volume_ml * 1000.0;
  EXPECT_NEAR(q.volume_mm3, mask_mm3, 0.01 * mask_mm3);
  // The mask's boundary: its signed distance's zero level on its own grid, unremeshed.
  const SurfaceMesh boundary = geometry::extract_isosurface(
      geometry::signed_distance(geometry::pad_mask(prepared.mask, 2)), 0.0);
  const geometry::SurfaceDistance d = geometry::surface_distance(skin, boundary);
  EXPECT_LE(d.mean_mm, 0.5 * 1.5) << "mean " << d.mean_mm << " mm, max " << d.max_mm << " mm";
  EXPECT_FALSE(geometry::self_intersects(skin));
}

// Issue 33's clinical case: a 512 x 512 x 130 mask at 0.6 x 0.6 x 1.6 mm, 100k triangles.
TEST(DisplaySkin, OnAClinicalSizeMaskMeetsTheBudgetVolumeAndDistanceTargets) {
  const geometry::PreparedMask prepared = geometry::prepare_mask(
      geometry::make_phantom({.spacing_mm = {0.6, 0.6, 1.6}, .size = {512, 512, 130}}));
  const SurfaceMesh skin = geometry::display_skin(prepared.mask, 100000);
  const geometry::MeshQuality q = geometry::measure_mesh(skin);
  EXPECT_TRUE(q.closed && q.manifold && q.outward);
  EXPECT_EQ(q.components, 1);
  EXPECT_NEAR(static_cast<double>(q.faces), 100000.0, 0.05 * 100000.0);
  const double mask_mm3 = prepared.report.kept_volume_ml * 1000.0;
  EXPECT_NEAR(q.volume_mm3, mask_mm3, 0.01 * mask_mm3);
  const SurfaceMesh boundary = geometry::extract_isosurface(
      geometry::signed_distance(geometry::pad_mask(prepared.mask, 2)), 0.0);
  EXPECT_LE(geometry::surface_distance(skin, boundary).mean_mm, 0.5 * 1.6);
}

// A ball on thick slices (1 x 1 x 4 mm): the mask's boundary is a staircase 4 mm a step; the
// display skin lies closer to a sphere (measured: radial spread 0.26 mm against the voxel
// boundary's 0.32 mm; each slice's own pixel outline is what is left) and encloses the voxels'
// volume (the isosurface of their distance, 1.4% less).
TEST(DisplaySkin, SmoothsTheSliceStaircaseOfAnAnisotropicMask) {
  LabelVolume volume = test::empty_volume(64, 1.0);
  volume.frame.spacing_mm = {1.0, 1.0, 4.0};
  const auto c = volume.frame.to_physical(32.0, 32.0, 8.0);  // the grid's middle
  test::paint_sphere(volume, c, 24.0, 1);
  const Mask mask = geometry::prepare_mask(volume).mask;
  const Eigen::RowVector3d centre(c[0], c[1], c[2]);
  const auto radial_rms = [&](const SurfaceMesh& m) {
    // About the mean radius: the staircase's ripple, not the voxelisation's bias.
    const Eigen::VectorXd r = (m.V.rowwise() - centre).rowwise().norm();
    return std::sqrt((r.array() - r.mean()).square().mean());
  };
  const SurfaceMesh boundary =
      geometry::extract_isosurface(geometry::signed_distance(geometry::pad_mask(mask, 2)), 0.0);
  const SurfaceMesh skin = geometry::display_skin(mask, 20000);
  EXPECT_LT(radial_rms(skin), 0.9 * radial_rms(boundary))
      << "skin " << radial_rms(skin) << " mm, voxel boundary " << radial_rms(boundary) << " mm";
  int64_t voxels = 0;
  for (const uint8_t b : mask.inside) voxels += b;
  const double voxel_volume = static_cast<double>(voxels) * mask.frame.voxel_volume_mm3();
  EXPECT_NEAR(geometry::measure_mesh(skin).volume_mm3, voxel_volume, 1e-3 * voxel_volume);
}

TEST(DisplaySkin, AStructureKeepsEveryPiece) {
  LabelVolume volume = test::empty_volume(48, 1.0);
  test::paint_sphere(volume, {14.0, 24.0, 24.0}, 6.0, 2);
  test::paint_sphere(volume, {34.0, 24.0, 24.0}, 8.0, 2);
  Mask mask;
  mask.frame = volume.frame;
  for (int32_t l : volume.labels) mask.inside.push_back(l == 2 ? 1 : 0);
  const SurfaceMesh both = geometry::structure_surface(mask, 4000, "vessels");
  EXPECT_EQ(geometry::measure_mesh(both).components, 2);
  EXPECT_EQ(geometry::measure_mesh(geometry::display_skin(mask, 4000)).components, 1);
  EXPECT_TRUE(geometry::measure_mesh(both).closed);
}

TEST(TaubinSmooth, DampsNoiseAndKeepsTheVolume) {
  LabelVolume volume = test::empty_volume(48, 1.0);
  test::paint_sphere(volume, {24.0, 24.0, 24.0}, 15.0, 1);
  const Mask mask = geometry::prepare_mask(volume).mask;
  SurfaceMesh m =
      geometry::extract_isosurface(geometry::signed_distance(geometry::pad_mask(mask, 2)), 0.0);
  const double volume_before = geometry::measure_mesh(m).volume_mm3;
  const Eigen::MatrixX3d before = m.V;
  geometry::taubin_smooth(m, 10);
  const double volume_after = geometry::measure_mesh(m).volume_mm3;
  EXPECT_NEAR(volume_after, volume_before, 0.01 * volume_before);
  EXPECT_GT((m.V - before).rowwise().norm().maxCoeff(), 0.05);  // it did move them
  EXPECT_EQ(geometry::measure_mesh(m).faces, m.F.rows());
}

TEST(DisplaySkin, ATooSmallBudgetIsRefusedByName) {
  const geometry::PreparedMask prepared =
      geometry::prepare_mask(geometry::make_phantom({.spacing_mm = {3.0, 3.0, 3.0}}));
  try {
    geometry::display_skin(prepared.mask, 50);
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::kInvalidInput);
    EXPECT_NE(std::string(e.what()).find("--display-triangles"), std::string::npos) << e.what();
  }
}

}  // namespace
