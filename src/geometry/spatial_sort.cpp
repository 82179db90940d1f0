#include "lamina/geometry/spatial_sort.h"

#include <meshoptimizer.h>

#include <algorithm>
#include <numeric>
#include <vector>

namespace lamina::geometry {

std::vector<int32_t> spatial_order(const Eigen::MatrixX3d& points) {
  const auto n = static_cast<size_t>(points.rows());
  // meshoptimizer takes float xyz triples; single precision is ample to order points.
  std::vector<float> xyz(3 * n);
  for (size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c)
      xyz[3 * i + c] = static_cast<float>(points(static_cast<Eigen::Index>(i), c));
  std::vector<unsigned int> remap(n);  // old index -> new index
  if (n > 0) meshopt_spatialSortRemap(remap.data(), xyz.data(), n, 3 * sizeof(float));
  return {remap.begin(), remap.end()};
}

void spatial_sort(const SurfaceMesh& in, SurfaceMesh& out) {
  const auto n = static_cast<size_t>(in.V.rows());
  const std::vector<int32_t> remap = spatial_order(in.V);  // old index -> new index

  SurfaceMesh sorted;
  sorted.V.resize(in.V.rows(), 3);
  for (size_t i = 0; i < n; ++i) sorted.V.row(remap[i]) = in.V.row(static_cast<Eigen::Index>(i));
  // Faces: renumber, rotate each so its smallest vertex comes first (winding kept), then order by
  // that vertex.
  Eigen::MatrixX3i F(in.F.rows(), 3);
  for (Eigen::Index t = 0; t < in.F.rows(); ++t) {
    int a = static_cast<int>(remap[in.F(t, 0)]), b = static_cast<int>(remap[in.F(t, 1)]),
        c = static_cast<int>(remap[in.F(t, 2)]);
    while (a > b || a > c) std::tie(a, b, c) = std::make_tuple(b, c, a);
    F.row(t) << a, b, c;
  }
  std::vector<Eigen::Index> order(static_cast<size_t>(F.rows()));
  std::iota(order.begin(), order.end(), Eigen::Index{0});
  std::stable_sort(order.begin(), order.end(), [&](Eigen::Index p, Eigen::Index q) {
    return std::make_tuple(F(p, 0), F(p, 1), F(p, 2)) < std::make_tuple(F(q, 0), F(q, 1), F(q, 2));
  });
  sorted.F.resize(F.rows(), 3);
  for (size_t t = 0; t < order.size(); ++t)
    sorted.F.row(static_cast<Eigen::Index>(t)) = F.row(order[t]);
  out = std::move(sorted);
}

}  // namespace lamina::geometry
