// The tetrahedra's stiffness as 3x3 blocks between nodes (TetAssembly): the pattern, once per
// model, after setup_tets() (it reads each node's corners). Each node's row holds its own block
// first, then one block per node it shares a tetrahedron with, in increasing order; each
// tetrahedron keeps the entries of its 16 corner pairs, so that assemble_tets() adds its blocks
// without searching.
#include <algorithm>

#include "solver.h"

namespace lamina::sim::detail {

void setup_tet_assembly(Solver& s) {
  TetAssembly& a = s.tets.assembly;
  const Tets& tets = s.model->tets;
  const int32_t n = s.model->node_count();
  const Eigen::Index nt = tets.size();
  // Each node's row: itself, then its neighbours through its tetrahedra (TetTerm::corners).
  a.offsets.assign(1, 0);
  a.column.clear();
  std::vector<int32_t> near;
  for (int32_t i = 0; i < n; ++i) {
    near.clear();
    for (int32_t k = s.tets.corner_offsets[i]; k < s.tets.corner_offsets[i + 1]; ++k)
      for (int c = 0; c < 4; ++c)
        if (const int32_t j = tets.T(s.tets.corners[k] / 4, c); j != i) near.push_back(j);
    std::sort(near.begin(), near.end());
    near.erase(std::unique(near.begin(), near.end()), near.end());
    a.column.push_back(i);
    a.column.insert(a.column.end(), near.begin(), near.end());
    a.offsets.push_back(static_cast<int32_t>(a.column.size()));
  }
  a.entry.resize(16 * static_cast<size_t>(nt));
  for (Eigen::Index q = 0; q < nt; ++q)
    for (int r = 0; r < 4; ++r) {
      const int32_t i = tets.T(q, r);
      for (int c = 0; c < 4; ++c) {
        const int32_t j = tets.T(q, c);
        const auto first = a.column.begin() + a.offsets[i],
                   last = a.column.begin() + a.offsets[i + 1];
        const auto at = j == i ? first : std::lower_bound(first + 1, last, j);
        a.entry[16 * static_cast<size_t>(q) + 4 * r + c] =
            static_cast<int32_t>(at - a.column.begin());
      }
    }
  a.block.assign(9 * a.column.size(), 0.0f);
  a.on = true;
}

}  // namespace lamina::sim::detail
