#pragma once
// A symmetric matrix of 3x3 blocks between nodes in a fixed pattern (BlockRows), and its
// conversion to the row-major sparse matrix the multigrid works on. The stiffness at rest and a
// step's assembled system are written into it block by block: no triplet list (28 million
// triplets, 450 MB and 3.5 s at 221,474 tetrahedra) and no sort. Internal to module sim.
#include <Eigen/SparseCore>
#include <cstdint>
#include <vector>

#include "lamina/model/model.h"

namespace lamina::sim::detail {

using SparseRows = Eigen::SparseMatrix<double, Eigen::RowMajor>;

struct BlockRows {
  int32_t rows = 0;              ///< block rows (= block columns): the movable nodes' rows
  std::vector<int32_t> offsets;  ///< per row + 1: its blocks
  std::vector<int32_t> column;   ///< per block: its column, increasing within a row
  std::vector<double> value;     ///< per block 9, row-major

  /// The block (r, c), or -1 outside the pattern.
  int32_t find(int32_t r, int32_t c) const;
  /// The 9 values of block (r, c), which must be in the pattern.
  double* at(int32_t r, int32_t c);
};

/// The pattern of `m`'s springs over the rows `row_of` (-1: not a row): each row's own block and
/// one per spring to another row. On a model with tetrahedra the springs are their edges, so
/// every pair of corners has its block. Values zero.
void spring_block_pattern(const Model& m, const std::vector<int32_t>& row_of, int32_t rows,
                          BlockRows& out);

/// `b` as a sparse matrix of 3 rows.size() unknowns, row 3 r + axis.
SparseRows to_sparse(const BlockRows& b);

}  // namespace lamina::sim::detail
