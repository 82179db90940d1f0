// Taubin smoothing over the mesh's unique edges, kept as a compressed row list so that each
// pass is one sweep with no allocation. Hand-written: CGAL's smooth_shape is an implicit
// mean-curvature flow (a sparse solve a step, and it shrinks the shape); this filter is linear
// time and volume-neutral to first order (docs/architecture.md).
#include "lamina/geometry/smooth_surface.h"

#include <vector>

#include "lamina/geometry/mesh_measures.h"

namespace lamina::geometry {

void taubin_smooth(SurfaceMesh& mesh, int iterations, double lambda, double mu) {
  const Eigen::Index n = mesh.V.rows();
  if (iterations <= 0 || n == 0) return;
  const auto edges = mesh_edges(mesh.F);
  std::vector<int> start(static_cast<size_t>(n) + 1, 0), ring(2 * edges.size());
  for (const auto& [a, b] : edges) ++start[a + 1], ++start[b + 1];
  for (Eigen::Index v = 0; v < n; ++v) start[v + 1] += start[v];
  std::vector<int> fill(start.begin(), start.end() - 1);
  for (const auto& [a, b] : edges) ring[fill[a]++] = b, ring[fill[b]++] = a;

  Eigen::MatrixX3d next(n, 3);
  const auto pass = [&](double factor) {
    for (Eigen::Index v = 0; v < n; ++v) {
      const int begin = start[v], end = start[v + 1];
      if (begin == end) {
        next.row(v) = mesh.V.row(v);
        continue;
      }
      Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
      for (int r = begin; r < end; ++r) sum += mesh.V.row(ring[r]);
      next.row(v) = mesh.V.row(v) + factor * (sum / (end - begin) - mesh.V.row(v));
    }
    mesh.V.swap(next);
  };
  for (int it = 0; it < iterations; ++it) {
    pass(lambda);
    pass(mu);
  }
}

}  // namespace lamina::geometry
