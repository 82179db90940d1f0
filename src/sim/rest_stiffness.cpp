// The stiffness at rest as one sparse matrix over the rows of the movable nodes: what the
// slowest vibration (lowest_frequency.cpp) and the multigrid's coarse levels (multigrid.cpp) are
// computed from. Every force term adds its own (force_terms.h); the volume term between layers
// adds none (LayerVolume). Written block by block into the springs' pattern (block_rows.h).
#include "block_rows.h"
#include "force_terms.h"
#include "solver.h"

namespace lamina::sim::detail {

void rest_stiffness_blocks(const Solver& s, const std::vector<int32_t>& row, int32_t rows,
                           BlockRows& K) {
  const Model& m = *s.model;
  spring_block_pattern(m, row, rows, K);
  for_each_term(Terms{}, s, [&](auto term) { decltype(term)::add_rest_stiffness(s, row, K); });
}

SparseRows rest_stiffness(const Solver& s, const std::vector<int32_t>& row, int32_t rows) {
  BlockRows K;
  rest_stiffness_blocks(s, row, rows, K);
  return to_sparse(K);
}

}  // namespace lamina::sim::detail
