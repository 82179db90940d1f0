// The tetrahedra's stiffness as 3x3 blocks between nodes (TetAssembly): the pattern, once per
// model, after setup_tets() (it reads each node's corners). Each node's row holds its own block
// first, then one block per node it shares a tetrahedron with, in increasing order; each
// tetrahedron keeps the entries of its 16 corner pairs, so that assemble_tets() adds its blocks
// without searching. assemble_tets() sums each step's blocks into it, for whichever energy the
// tetrahedra store.
#include <algorithm>

#include "force_terms.h"
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
  // Three floats past the last block: assembled_tet_product_packed() loads a block's last row
  // as four.
  a.block.assign(9 * a.column.size() + 3, 0.0f);
  a.packed.assign(4 * static_cast<size_t>(n), 0.0);
  a.on = true;
}

void assemble_tets(Solver& s, int threads) {
  TetTerm& tt = s.tets;
  TetAssembly& a = tt.assembly;
  const auto nt = static_cast<int64_t>(s.model->tets.size());
  float* __restrict blocks = a.block.data();
  // Each thread owns a range of node rows and adds only to them: a block of tetrahedra with
  // corners in both ranges is computed by both threads (no atomics, no second buffer), and each
  // row sums its tetrahedra in the same order whatever the thread count.
  for_slices(s.model->node_count(), threads, [&](int64_t lo, int64_t hi, int) {
    const auto owned = [&](int32_t i) { return i >= lo && i < hi; };
    std::fill(blocks + 9 * static_cast<int64_t>(a.offsets[lo]),
              blocks + 9 * static_cast<int64_t>(a.offsets[hi]), 0.0f);
    for (const int32_t k : s.active_tets) {
      const TetBlock& b = tt.block[static_cast<size_t>(k)];
      bool any = false;
      for (int c = 0; c < 4; ++c)
        for (int l = 0; l < kTetLanes; ++l) any |= owned(b.node[c][l]);
      if (!any) continue;
      double out[16][9][kTetLanes];
      with_tet_energy(s, [&](auto energy) {
        decltype(energy)::block_stiffness(s, static_cast<size_t>(k), out);
      });
      for (int l = 0; l < kTetLanes && static_cast<int64_t>(k) * kTetLanes + l < nt; ++l) {
        const int32_t* entry = a.entry.data() + 16 * (static_cast<int64_t>(k) * kTetLanes + l);
        for (int r = 0; r < 4; ++r) {
          if (!owned(b.node[r][l])) continue;
          for (int c = 0; c < 4; ++c) {
            float* o = blocks + 9 * static_cast<int64_t>(entry[4 * r + c]);
            for (int v = 0; v < 9; ++v) o[v] += static_cast<float>(out[4 * r + c][v][l]);
          }
        }
      }
    }
  });
}

}  // namespace lamina::sim::detail
