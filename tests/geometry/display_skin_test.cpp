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
