#include "lamina/geometry/spatial_sort.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>

#include "lamina/geometry/extract_isosurface.h"
#include "lamina/geometry/mask_filters.h"
#include "lamina/geometry/mesh_measures.h"
#include "lamina/geometry/prepare_mask.h"
#include "lamina/geometry/remesh.h"
#include "support/volumes.h"

namespace {

using namespace lamina;

// A remeshed sphere with its vertices in random order.
SurfaceMesh shuffled_sphere() {
  LabelVolume v = test::empty_volume(40);
  test::paint_sphere(v, v.frame.to_physical(19.5, 19.5, 19.5), 15.0, 1);
  const DistanceField d =
      geometry::signed_distance(geometry::prepare_mask(v, {.pad_voxels = 2}).mask);
  const SurfaceMesh m =
      geometry::remesh(geometry::extract_isosurface(d, 0.0), {.target_edge_mm = 1.5});
  std::vector<int> perm(static_cast<size_t>(m.V.rows()));
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), std::mt19937(3));
  SurfaceMesh out;
  out.V.resize(m.V.rows(), 3);
  for (size_t i = 0; i < perm.size(); ++i)
    out.V.row(perm[i]) = m.V.row(static_cast<Eigen::Index>(i));
  out.F = m.F;
  for (Eigen::Index k = 0; k < out.F.size(); ++k) out.F.data()[k] = perm[out.F.data()[k]];
  return out;
}

// Mean index distance between the two ends of an edge, as a fraction of the vertex count.
double mean_edge_span(const SurfaceMesh& m) {
  double sum = 0.0;
  const auto edges = geometry::mesh_edges(m.F);
  for (const auto& [a, b] : edges) sum += std::abs(a - b);
  return sum / static_cast<double>(edges.size()) / static_cast<double>(m.V.rows());
}

TEST(SpatialSort, SameSurfaceWithNeighboursNearInMemory) {
  const SurfaceMesh in = shuffled_sphere();
  ASSERT_GT(in.V.rows(), 500);
  SurfaceMesh out;
  geometry::spatial_sort(in, out);

  // The same points and the same closed, outward surface.
  ASSERT_EQ(out.V.rows(), in.V.rows());
  ASSERT_EQ(out.F.rows(), in.F.rows());
  auto sorted_rows = [](const Eigen::MatrixX3d& V) {
    std::vector<std::array<double, 3>> r;
    for (Eigen::Index i = 0; i < V.rows(); ++i) r.push_back({V(i, 0), V(i, 1), V(i, 2)});
    std::sort(r.begin(), r.end());
    return r;
  };
  EXPECT_EQ(sorted_rows(out.V), sorted_rows(in.V));
  const auto qi = geometry::measure_mesh(in), qo = geometry::measure_mesh(out);
  EXPECT_TRUE(qo.closed && qo.manifold && qo.outward);
  EXPECT_NEAR(qo.volume_mm3, qi.volume_mm3, 1e-9 * qi.volume_mm3);
  EXPECT_NEAR(qo.area_mm2, qi.area_mm2, 1e-9 * qi.area_mm2);

  // Faces ordered by their first (smallest) vertex.
  for (Eigen::Index t = 0; t < out.F.rows(); ++t) {
    EXPECT_LT(out.F(t, 0), out.F(t, 1));
    EXPECT_LT(out.F(t, 0), out.F(t, 2));
    if (t > 0) EXPECT_LE(out.F(t - 1, 0), out.F(t, 0));
  }

  // Locality: a random order puts an edge's ends a third of the array apart on average; the
  // space-filling curve keeps them within a few percent.
  const double before = mean_edge_span(in), after = mean_edge_span(out);
  EXPECT_GT(before, 0.25);
  EXPECT_LT(after, 0.1 * before) << "before " << before << " after " << after;

  // In place gives the same result.
  SurfaceMesh again = in;
  geometry::spatial_sort(again, again);
  EXPECT_EQ(again.V, out.V);
  EXPECT_EQ(again.F, out.F);
}

}  // namespace
