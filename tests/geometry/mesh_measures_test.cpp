#include "lamina/geometry/mesh_measures.h"

#include <gtest/gtest.h>

#include "support/meshes.h"

namespace {

using namespace lamina;
using geometry::measure_mesh;

TEST(MeasureMesh, OctahedronIsClosedManifoldOutward) {
  const SurfaceMesh m = test::octahedron(2.0);
  const auto q = measure_mesh(m);
  EXPECT_TRUE(q.closed);
  EXPECT_TRUE(q.manifold);
  EXPECT_TRUE(q.outward);
  EXPECT_EQ(q.components, 1);
  EXPECT_EQ(q.degenerate_faces, 0);
  EXPECT_NEAR(q.volume_mm3, 4.0 / 3.0 * 8.0, 1e-12);  // (4/3) r^3 for an octahedron
  EXPECT_NEAR(q.min_angle_deg, 60.0, 1e-9);
  EXPECT_NEAR(q.mean_edge_mm, 2.0 * std::sqrt(2.0), 1e-12);
}

TEST(MeasureMesh, DetectsInwardOpenAndNonManifold) {
  SurfaceMesh flipped = test::octahedron();
  flipped.F.col(1).swap(flipped.F.col(2));
  EXPECT_FALSE(measure_mesh(flipped).outward);
  EXPECT_TRUE(measure_mesh(flipped).closed);

  SurfaceMesh open = test::octahedron();
  open.F.conservativeResize(7, 3);  // one face missing: a hole
  EXPECT_FALSE(measure_mesh(open).closed);

  // Two octahedra sharing one vertex: closed edges, but a pinched (non-manifold) vertex.
  SurfaceMesh a = test::octahedron(), b = test::octahedron(1.0, Eigen::RowVector3d(2, 0, 0));
  SurfaceMesh pinched = geometry::merge_meshes({a, b});
  for (Eigen::Index f = 8; f < 16; ++f)
    for (int c = 0; c < 3; ++c)
      if (pinched.F(f, c) == 6 + 1) pinched.F(f, c) = 0;  // b's vertex (1,0,0) is a's vertex 0
  EXPECT_FALSE(measure_mesh(pinched).manifold);

  SurfaceMesh inconsistent = test::octahedron();
  std::swap(inconsistent.F(0, 1), inconsistent.F(0, 2));  // one face wound the wrong way
  EXPECT_FALSE(measure_mesh(inconsistent).manifold);
  EXPECT_FALSE(measure_mesh(inconsistent).closed);
}

TEST(MeasureMesh, CountsDegenerateFaces) {
  SurfaceMesh m = test::octahedron();
  m.V.row(4) = m.V.row(0);  // collapse the top vertex onto another: zero-area faces
  EXPECT_GT(measure_mesh(m).degenerate_faces, 0);
}

TEST(SplitMerge, RoundTrip) {
  const SurfaceMesh a = test::octahedron(), b = test::octahedron(0.5, Eigen::RowVector3d(5, 0, 0));
  const SurfaceMesh both = geometry::merge_meshes({a, b});
  const auto parts = geometry::split_components(both);
  ASSERT_EQ(parts.size(), 2u);
  EXPECT_EQ(measure_mesh(both).components, 2);
  EXPECT_TRUE(parts[0].V.isApprox(a.V));
  EXPECT_EQ(parts[0].F, a.F);
  EXPECT_TRUE(parts[1].V.isApprox(b.V));
  EXPECT_EQ(parts[1].F, b.F);
}

TEST(MeshEdges, UniqueSortedUndirected) {
  const auto e = geometry::mesh_edges(test::octahedron().F);
  EXPECT_EQ(e.size(), 12u);  // Euler: V - E + F = 2 -> 6 - 12 + 8
  for (const auto& [a, b] : e) EXPECT_LT(a, b);
  EXPECT_TRUE(std::is_sorted(e.begin(), e.end()));
}

}  // namespace
