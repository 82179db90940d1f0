// The stiffness at rest as one sparse matrix over the rows of the movable nodes: what the
// slowest vibration (lowest_frequency.cpp) and the multigrid's coarse levels (multigrid.cpp) are
// computed from. k u u^T per spring (at its rest length: no geometric term), the tetrahedra's
// coupling and volume, support and anchors on the diagonal. The volume term between layers is
// left out: a rank-one term per layer, dense over the layer, that the slow bending modes barely
// excite and that would fill the matrix.
#include <Eigen/SparseCore>
#include <vector>

#include "solver.h"

namespace lamina::sim::detail {

Eigen::SparseMatrix<double> rest_stiffness(const Solver& s, const std::vector<int32_t>& row,
                                           int32_t rows) {
  const Model& m = *s.model;
  std::vector<Eigen::Triplet<double>> t;
  t.reserve((s.tets.on ? 144 * static_cast<size_t>(m.tets.size()) : 36 * m.springs.size()) +
            3 * static_cast<size_t>(rows));
  const Springs& sp = m.springs;
  for (size_t e = 0; !s.tets.on && e < sp.size(); ++e) {  // else inside the tetrahedra
    const int32_t a = row[sp.i[e]], b = row[sp.j[e]];
    if (a < 0 && b < 0) continue;
    const Eigen::Vector3d u = (m.X.row(sp.j[e]) - m.X.row(sp.i[e])).normalized();
    const Eigen::Matrix3d k = s.springs.stiffness_n_per_m[e] * u * u.transpose();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) {
        if (a >= 0) t.emplace_back(3 * a + r, 3 * a + c, k(r, c));
        if (b >= 0) t.emplace_back(3 * b + r, 3 * b + c, k(r, c));
        if (a >= 0 && b >= 0) {
          t.emplace_back(3 * a + r, 3 * b + c, -k(r, c));
          t.emplace_back(3 * b + r, 3 * a + c, -k(r, c));
        }
      }
  }
  add_tet_stiffness_triplets(s, row, t);
  for (int32_t i = 0; i < m.node_count(); ++i)
    if (row[i] >= 0)
      for (int c = 0; c < 3; ++c)
        t.emplace_back(3 * row[i] + c, 3 * row[i] + c, s.support.stiffness_n_per_m[i]);
  Eigen::SparseMatrix<double> K(3 * rows, 3 * rows);
  K.setFromTriplets(t.begin(), t.end());
  return K;
}

}  // namespace lamina::sim::detail
