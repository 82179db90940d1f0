// The tetrahedra's stiffness as 3x3 blocks between nodes (TetAssembly): the pattern, once per
// model, after setup_tets() (it reads each node's corners). Each node's row holds its own block
// first, then one block per node it shares a tetrahedron with, in increasing order; each
// tetrahedron keeps the entries of its 16 corner pairs, so that assemble_tets() adds its blocks
// without searching. assemble_tets() sums each step's blocks into it, for whichever energy the
// tetrahedra store.
#include <fmt/format.h>

#include <algorithm>

#include "force_terms.h"
#include "lamina/core/error.h"
#include "solver.h"

namespace lamina::sim::detail {

void setup_tet_assembly(Solver& s) {
  TetAssembly& a = s.tets.assembly;
  const Tets& tets = s.model->tets;
  const SpringTerm& springs = s.springs;  // its per-node CSR (setup_springs)
  const int32_t n = s.model->node_count();
  const Eigen::Index nt = tets.size();
  const std::vector<int32_t>& corner_offsets = s.tets.corner_offsets;
  const std::vector<int32_t>& corners = s.tets.corners;
  // Each node's row: itself, then its springs' other ends, which are the nodes it shares a
  // tetrahedron with (the springs are the tetrahedra's edges, identify_tets checks each edge is
  // one) and are in increasing order (the springs are sorted by (i, j)). It is made again at
  // every cut (carry_over), so taken from there, and each tetrahedron's entries found through a
  // scratch table of where a neighbour sits in its row, node by node on the threads (each
  // (tetrahedron, corner) belongs to one node's row): a binary search per corner pair was 100 ms
  // of a 48k-node cut event's 175 (docs/benchmarks.md).
  a.offsets.assign(static_cast<size_t>(n) + 1, 0);
  for (int32_t i = 0; i < n; ++i)
    a.offsets[i + 1] = a.offsets[i] + 1 + springs.adj_offsets[i + 1] - springs.adj_offsets[i];
  a.column.resize(static_cast<size_t>(a.offsets[n]));
  a.entry.resize(16 * static_cast<size_t>(nt));
  int32_t missing = -1;  // a node with a tetrahedron edge that is no spring
#pragma omp parallel
  {
    // stamp[j] == i: j is in row i, at place[j].
    std::vector<int32_t> stamp(static_cast<size_t>(n), -1), place(static_cast<size_t>(n), 0);
#pragma omp for schedule(static) reduction(max : missing)
    for (int32_t i = 0; i < n; ++i) {
      int32_t* row = a.column.data() + a.offsets[i];
      row[0] = i;
      std::copy(springs.adj_other.begin() + springs.adj_offsets[i],
                springs.adj_other.begin() + springs.adj_offsets[i + 1], row + 1);
      for (int32_t e = a.offsets[i]; e < a.offsets[i + 1]; ++e) {
        stamp[a.column[e]] = i;
        place[a.column[e]] = e;
      }
      for (int32_t k = corner_offsets[i]; k < corner_offsets[i + 1]; ++k) {
        const int32_t q = corners[k] / 4, r = corners[k] % 4;
        for (int c = 0; c < 4; ++c) {
          const int32_t j = tets.T(q, c);
          if (stamp[j] != i) missing = std::max(missing, i);
          a.entry[16 * static_cast<size_t>(q) + 4 * r + c] = place[j];
        }
      }
    }
  }
  if (missing >= 0)
    throw Error(
        ErrorKind::kInternal,
        fmt::format("node {} shares a tetrahedron with a node it has no spring to", missing));
  // Three floats past the last block: assembled_tet_product_packed() loads a block's last row
  // as four.
  a.block.assign(9 * a.column.size() + 3, 0.0f);
  a.packed.assign(4 * static_cast<size_t>(n), 0.0);
  a.on = true;
}

std::vector<int32_t> table_blocks(const TetAssembly& a, const std::vector<int32_t>& row_of,
                                  const BlockRows& out) {
  const auto n = static_cast<int32_t>(a.offsets.size()) - 1;
  std::vector<int32_t> block_of(a.column.size(), -1);
  int32_t outside = 0;  // entries between two rows that out's pattern lacks
#pragma omp parallel for schedule(static) reduction(+ : outside)
  for (int32_t i = 0; i < n; ++i) {
    const int32_t r = row_of[i];
    if (r < 0) continue;
    for (int32_t e = a.offsets[i]; e < a.offsets[i + 1]; ++e) {
      const int32_t c = row_of[a.column[e]];
      if (c >= 0 && (block_of[e] = out.find(r, c)) < 0) ++outside;
    }
  }
  if (outside > 0)
    throw Error(ErrorKind::kInternal, "a stiffness block outside the springs' pattern");
  return block_of;
}

void add_element_rows(const Eigen::Matrix<double, 12, 12>& k12, const int32_t corner[4],
                      const int32_t* entry, const std::vector<int32_t>& row_of,
                      const std::vector<int32_t>& block_of, int64_t lo, int64_t hi,
                      BlockRows& out) {
  for (int r = 0; r < 4; ++r) {
    const int32_t row = row_of[corner[r]];
    if (row < lo || row >= hi) continue;  // another thread's, or held (-1)
    for (int c = 0; c < 4; ++c) {
      const int32_t at = block_of[static_cast<size_t>(entry[4 * r + c])];
      if (at < 0) continue;  // a held corner: no column
      double* block = out.value.data() + 9 * static_cast<size_t>(at);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) block[3 * i + j] += k12(3 * r + i, 3 * c + j);
    }
  }
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
