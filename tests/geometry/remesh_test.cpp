#include "lamina/geometry/remesh.h"

#include <gtest/gtest.h>

#include "lamina/geometry/extract_isosurface.h"
#include "lamina/geometry/mask_filters.h"
#include "lamina/geometry/mesh_measures.h"
#include "lamina/geometry/prepare_mask.h"
#include "support/meshes.h"
#include "support/volumes.h"

namespace {

using namespace lamina;

SurfaceMesh sphere_isosurface(double r, double iso = 0.0) {
  LabelVolume v = test::empty_volume(40);
  test::paint_sphere(v, v.frame.to_physical(19.5, 19.5, 19.5), r, 1);
  const DistanceField d =
      geometry::signed_distance(geometry::prepare_mask(v, {.pad_voxels = 2}).mask);
  return geometry::extract_isosurface(d, iso);
}

TEST(Remesh, NearUniformClosedManifoldAndOnTheSurface) {
  const SurfaceMesh raw = sphere_isosurface(15.0);
  const double raw_volume = geometry::measure_mesh(raw).volume_mm3;
  const SurfaceMesh m = geometry::remesh(raw, {.target_edge_mm = 3.0});
  const auto q = geometry::measure_mesh(m);
  EXPECT_TRUE(q.closed);
  EXPECT_TRUE(q.manifold);
  EXPECT_TRUE(q.outward);
  EXPECT_EQ(q.components, 1);
  EXPECT_EQ(q.degenerate_faces, 0);
  EXPECT_FALSE(geometry::self_intersects(m));
  // Near-uniform: mean within 20% of the target, no edge beyond CGAL's 4/3 split bound (+slack
  // for the final projection), well-shaped triangles.
  EXPECT_NEAR(q.mean_edge_mm, 3.0, 0.6);
  EXPECT_LT(q.max_edge_mm, 3.0 * 4.0 / 3.0 * 1.15);
  EXPECT_GT(q.min_angle_deg, 20.0);
  EXPECT_NEAR(q.volume_mm3 / raw_volume, 1.0, 0.02);
  EXPECT_LT(q.faces, geometry::measure_mesh(raw).faces);
}

TEST(Remesh, KeepsAnInwardOrientationIfGivenOne) {
  SurfaceMesh raw = sphere_isosurface(10.0);
  raw.F.col(1).swap(raw.F.col(2));
  EXPECT_FALSE(geometry::measure_mesh(geometry::remesh(raw, {.target_edge_mm = 2.5})).outward);
}

TEST(Nesting, InnerSphereIsNestedTouchingIsNot) {
  const SurfaceMesh outer = geometry::remesh(sphere_isosurface(15.0), {.target_edge_mm = 3.0});
  const SurfaceMesh inner =
      geometry::remesh(sphere_isosurface(15.0, -5.0), {.target_edge_mm = 3.0});
  const geometry::Nesting n = geometry::check_nesting(outer, inner);
  EXPECT_TRUE(n.nested());
  EXPECT_NEAR(n.min_gap_mm, 5.0, 1.0);
  // Swapped: the outer surface is not inside the inner one.
  EXPECT_FALSE(geometry::check_nesting(inner, outer).nested());
  // A shifted copy pokes through: the surfaces intersect.
  SurfaceMesh shifted = inner;
  shifted.V.col(0).array() += 8.0;
  const geometry::Nesting s = geometry::check_nesting(outer, shifted);
  EXPECT_TRUE(s.surfaces_intersect);
  EXPECT_FALSE(s.nested());
}

TEST(SelfIntersection, DetectsTwoOverlappingShells) {
  const SurfaceMesh a = test::octahedron(1.0),
                    b = test::octahedron(1.0, Eigen::RowVector3d(0.5, 0.2, 0.1));
  EXPECT_FALSE(geometry::self_intersects(a));
  EXPECT_TRUE(geometry::self_intersects(geometry::merge_meshes({a, b})));
}

}  // namespace
