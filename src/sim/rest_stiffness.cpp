// The stiffness at rest as one sparse matrix over the rows of the movable nodes: what the
// slowest vibration (lowest_frequency.cpp) and the multigrid's coarse levels (multigrid.cpp) are
// computed from. k u u^T per spring (at its rest length: no geometric term), the tetrahedra's
// coupling and volume, support and anchors on the diagonal. The volume term between layers is
// left out: a rank-one term per layer, dense over the layer, that the slow bending modes barely
// excite and that would fill the matrix. Written block by block into the springs' pattern
// (block_rows.h).
#include "block_rows.h"
#include "solver.h"

namespace lamina::sim::detail {

void rest_stiffness_blocks(const Solver& s, const std::vector<int32_t>& row, int32_t rows,
                           BlockRows& K) {
  const Model& m = *s.model;
  spring_block_pattern(m, row, rows, K);
  const Springs& sp = m.springs;
  for (size_t e = 0; !s.tets.on && e < sp.size(); ++e) {  // else inside the tetrahedra
    const int32_t a = row[sp.i[e]], b = row[sp.j[e]];
    if (a < 0 && b < 0) continue;
    const Eigen::Vector3d u = (m.X.row(sp.j[e]) - m.X.row(sp.i[e])).normalized();
    const Eigen::Matrix3d k = s.springs.stiffness_n_per_m[e] * u * u.transpose();
    const auto add = [&](int32_t r, int32_t c, double sign) {
      double* block = K.at(r, c);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) block[3 * i + j] += sign * k(i, j);
    };
    if (a >= 0) add(a, a, 1.0);
    if (b >= 0) add(b, b, 1.0);
    if (a >= 0 && b >= 0) add(a, b, -1.0), add(b, a, -1.0);
  }
  add_tet_rest_stiffness(s, row, K);
  for (int32_t i = 0; i < m.node_count(); ++i)
    if (row[i] >= 0) {
      double* block = K.at(row[i], row[i]);
      for (int c = 0; c < 3; ++c) block[4 * c] += s.support.stiffness_n_per_m[i];
    }
}

SparseRows rest_stiffness(const Solver& s, const std::vector<int32_t>& row, int32_t rows) {
  BlockRows K;
  rest_stiffness_blocks(s, row, rows, K);
  return to_sparse(K);
}

}  // namespace lamina::sim::detail
