#pragma once
// A sparse matrix of small dense blocks in single precision (FloatBlocks) and its threaded
// product with a double vector: the multigrid's coarse operators (6x6 blocks, one coarse node's
// six rigid motions), its prolongations (3x6 from the finest level, 6x6 below) and restrictions.
// Eigen's double CSR streams 12 bytes a nonzero (value and column) and runs on one thread; these
// stream 4 bytes a nonzero and a column per block, on the step's threads (issue 48, item 3:
// docs/benchmarks.md measures both). The preconditioner needs no more than single precision: it
// only has to be the same symmetric operator every time, and a stored R is P's exact transpose
// and a stored A_ji is A_ij's float. Internal to module sim.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "block_rows.h"

namespace lamina::sim::detail {

struct FloatBlocks {
  int32_t block_rows = 0, block_cols = 0;  ///< blocks down and across
  int br = 0, bc = 0;                      ///< one block's rows and columns (3 or 6)
  std::vector<int32_t> offsets;            ///< per block row + 1: its blocks
  std::vector<int32_t> column;             ///< per block: its block column, increasing in a row
  std::vector<float> value;                ///< per block br x bc, row-major
  bool empty() const { return offsets.empty(); }
  int64_t nonzeros() const { return static_cast<int64_t>(value.size()); }
};

/// `m` (rows a multiple of `br`, columns of `bc`) as blocks: every block that holds a stored
/// entry of `m`, its other entries zero.
void to_float_blocks(const SparseRows& m, int br, int bc, FloatBlocks& out);

/// What multiply() does with M x: y = M x, y = b - M x (a residual), or y += M x.
enum class BlockProduct { kSet, kResidual, kAdd };

/// y = M x, b - M x or y + M x on `threads` threads (one below kThreadedFloats of values: a
/// parallel region costs more than a small level's product). Allocates nothing; y must have its
/// size (M's rows), and must not be x.
void multiply(const FloatBlocks& m, const Eigen::VectorXd& x, Eigen::VectorXd& y, int threads,
              BlockProduct kind = BlockProduct::kSet, const Eigen::VectorXd* b = nullptr);

/// Below this many stored values a product runs on one thread.
constexpr int64_t kThreadedFloats = int64_t{1} << 16;

}  // namespace lamina::sim::detail
