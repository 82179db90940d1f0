// The tetrahedra's stiffness as 3x3 blocks between nodes (TetAssembly): the pattern, once per
// model. Each node's row holds its own block first, then one block per node it shares a
// tetrahedron with, in increasing order; each tetrahedron keeps the entries of its 16 corner
// pairs, so that assemble_tets() adds its blocks without searching.
#include <algorithm>

#include "solver.h"

namespace lamina::sim::detail {

void setup_tet_assembly(Solver& s) {
  TetAssembly& a = s.tets.assembly;
  const Tets& tets = s.model->tets;
  const int32_t n = s.model->node_count();
  const Eigen::Index nt = tets.size();
  // Each node's neighbours through the tetrahedra, itself first.
  std::vector<std::vector<int32_t>> near(static_cast<size_t>(n));
  for (Eigen::Index q = 0; q < nt; ++q)
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c)
        if (c != r) near[tets.T(q, r)].push_back(tets.T(q, c));
  a.offsets.assign(1, 0);
  a.column.clear();
  for (int32_t i = 0; i < n; ++i) {
    std::vector<int32_t>& v = near[static_cast<size_t>(i)];
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
    a.column.push_back(i);
    a.column.insert(a.column.end(), v.begin(), v.end());
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
