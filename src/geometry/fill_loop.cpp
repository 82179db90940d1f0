// A hole's boundary closed with CGAL's hole filling (PMP::triangulate_hole_polyline: a 2D
// constrained Delaunay triangulation when the loop is near planar, as a cut's section is, else
// the minimum-area 3D triangulation).
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>

#include <vector>

#include "lamina/geometry/split_surface.h"

namespace lamina::geometry {

Eigen::MatrixX3i fill_loop(const Eigen::MatrixX3d& loop) {
  using Point = CGAL::Exact_predicates_inexact_constructions_kernel::Point_3;
  const auto n = static_cast<int>(loop.rows());
  if (n < 3) return {};
  std::vector<Point> points;
  points.reserve(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) points.emplace_back(loop(k, 0), loop(k, 1), loop(k, 2));
  // How far from its fitted plane a loop may lie and still be filled in 2D: a quarter of its
  // largest extent. CGAL's default is a quarter of the loop's extent along z, which assumes a
  // hole facing up: a section on a horizontal blade (extent along z about zero) was refused the
  // 2D triangulation for rounding alone and filled by the 3D Delaunay search instead, half of a
  // progressive cut's time with the anatomy (docs/benchmarks.md).
  const Eigen::Vector3d extent = loop.colwise().maxCoeff() - loop.colwise().minCoeff();
  std::vector<CGAL::Triple<int, int, int>> tris;
  CGAL::Polygon_mesh_processing::triangulate_hole_polyline(
      points, std::back_inserter(tris),
      CGAL::parameters::use_2d_constrained_delaunay_triangulation(true).threshold_distance(
          0.25 * extent.maxCoeff()));
  Eigen::MatrixX3i F(static_cast<Eigen::Index>(tris.size()), 3);
  for (size_t t = 0; t < tris.size(); ++t)
    F.row(static_cast<Eigen::Index>(t)) << tris[t].first, tris[t].second, tris[t].third;
  // The winding: a loop edge (k, k+1) must run k+1 -> k in its triangle.
  for (Eigen::Index t = 0; t < F.rows(); ++t)
    for (int c = 0; c < 3; ++c) {
      const int a = F(t, c), b = F(t, (c + 1) % 3);
      if ((a + 1) % n == b) {  // runs k -> k+1: every triangle the other way
        F.col(1).swap(F.col(2));
        return F;
      }
      if ((b + 1) % n == a) return F;
    }
  return F;
}

}  // namespace lamina::geometry
