// FloatBlocks (float_blocks.h): conversion from the multigrid's double CSR and the product.
#include "float_blocks.h"

#include <algorithm>

#include "lamina/core/error.h"
#include "solver.h"  // on_threads

namespace lamina::sim::detail {

void to_float_blocks(const SparseRows& m, int br, int bc, FloatBlocks& out) {
  if (br <= 0 || bc <= 0 || m.rows() % br != 0 || m.cols() % bc != 0)
    throw Error(ErrorKind::kInternal, "a matrix that does not divide into its blocks");
  out.br = br;
  out.bc = bc;
  out.block_rows = static_cast<int32_t>(m.rows() / br);
  out.block_cols = static_cast<int32_t>(m.cols() / bc);
  out.offsets.assign(1, 0);
  out.column.clear();
  // Each block row's block columns: those of its rows' entries, sorted, once each.
  for (int32_t i = 0; i < out.block_rows; ++i) {
    const auto first = static_cast<int64_t>(out.column.size());
    for (int r = 0; r < br; ++r)
      for (SparseRows::InnerIterator it(m, static_cast<Eigen::Index>(br) * i + r); it; ++it)
        out.column.push_back(static_cast<int32_t>(it.col() / bc));
    const auto begin = out.column.begin() + first;
    std::sort(begin, out.column.end());
    out.column.erase(std::unique(begin, out.column.end()), out.column.end());
    out.offsets.push_back(static_cast<int32_t>(out.column.size()));
  }
  const size_t size = static_cast<size_t>(br) * static_cast<size_t>(bc);
  out.value.assign(size * out.column.size(), 0.0F);
  for (int32_t i = 0; i < out.block_rows; ++i) {
    const auto first = out.column.begin() + out.offsets[i],
               last = out.column.begin() + out.offsets[i + 1];
    for (int r = 0; r < br; ++r)
      for (SparseRows::InnerIterator it(m, static_cast<Eigen::Index>(br) * i + r); it; ++it) {
        const auto block =
            static_cast<size_t>(std::lower_bound(first, last, static_cast<int32_t>(it.col() / bc)) -
                                out.column.begin());
        out.value[size * block + static_cast<size_t>(bc * r) + it.col() % bc] =
            static_cast<float>(it.value());
      }
  }
}

namespace {

// Block rows [row0, row1) of the product, BR x BC blocks known at compile time so that a block
// row's sums stay in registers and a block's columns are one vector operation.
template <int BR, int BC>
void rows_product(const FloatBlocks& m, const double* x, double* y, const double* b,
                  BlockProduct kind, int32_t row0, int32_t row1) {
  const int32_t* offsets = m.offsets.data();
  const int32_t* column = m.column.data();
  const float* value = m.value.data();
  for (int32_t i = row0; i < row1; ++i) {
    double acc[BR] = {};
    for (int32_t k = offsets[i]; k < offsets[i + 1]; ++k) {
      const float* v = value + static_cast<int64_t>(BR * BC) * k;
      const double* xs = x + static_cast<int64_t>(BC) * column[k];
      for (int r = 0; r < BR; ++r) {
        double sum = 0.0;
        for (int c = 0; c < BC; ++c) sum += static_cast<double>(v[BC * r + c]) * xs[c];
        acc[r] += sum;
      }
    }
    double* ys = y + static_cast<int64_t>(BR) * i;
    if (kind == BlockProduct::kSet)
      for (int r = 0; r < BR; ++r) ys[r] = acc[r];
    else if (kind == BlockProduct::kAdd)
      for (int r = 0; r < BR; ++r) ys[r] += acc[r];
    else
      for (int r = 0; r < BR; ++r) ys[r] = b[static_cast<int64_t>(BR) * i + r] - acc[r];
  }
}

// The same for a block shape without its own instance.
void rows_product_any(const FloatBlocks& m, const double* x, double* y, const double* b,
                      BlockProduct kind, int32_t row0, int32_t row1) {
  const int br = m.br, bc = m.bc;
  for (int32_t i = row0; i < row1; ++i)
    for (int r = 0; r < br; ++r) {
      double acc = 0.0;
      for (int32_t k = m.offsets[i]; k < m.offsets[i + 1]; ++k)
        for (int c = 0; c < bc; ++c)
          acc += static_cast<double>(m.value[static_cast<size_t>(br * bc) * k + bc * r + c]) *
                 x[static_cast<int64_t>(bc) * m.column[k] + c];
      const int64_t row = static_cast<int64_t>(br) * i + r;
      y[row] = kind == BlockProduct::kSet   ? acc
               : kind == BlockProduct::kAdd ? y[row] + acc
                                            : b[row] - acc;
    }
}

void rows(const FloatBlocks& m, const double* x, double* y, const double* b, BlockProduct kind,
          int32_t row0, int32_t row1) {
  if (m.br == 6 && m.bc == 6)
    rows_product<6, 6>(m, x, y, b, kind, row0, row1);
  else if (m.br == 3 && m.bc == 6)
    rows_product<3, 6>(m, x, y, b, kind, row0, row1);
  else if (m.br == 6 && m.bc == 3)
    rows_product<6, 3>(m, x, y, b, kind, row0, row1);
  else if (m.br == 3 && m.bc == 3)
    rows_product<3, 3>(m, x, y, b, kind, row0, row1);
  else
    rows_product_any(m, x, y, b, kind, row0, row1);
}

// The first block row of thread t's slice: slices of equal blocks, not of equal rows (a
// restriction's rows hold a whole aggregate each, a prolongation's one block).
int32_t slice_start(const FloatBlocks& m, int t, int T) {
  const int64_t target = static_cast<int64_t>(m.offsets.back()) * t / T;
  return static_cast<int32_t>(std::lower_bound(m.offsets.begin(), m.offsets.end() - 1, target) -
                              m.offsets.begin());
}

}  // namespace

void multiply(const FloatBlocks& m, const Eigen::VectorXd& x, Eigen::VectorXd& y, int threads,
              BlockProduct kind, const Eigen::VectorXd* b) {
  const double* bp = kind == BlockProduct::kResidual ? b->data() : nullptr;
  on_threads(m.nonzeros() < kThreadedFloats ? 1 : threads, [&](int t, int T) {
    const int32_t row0 = slice_start(m, t, T);
    const int32_t row1 = t + 1 == T ? m.block_rows : slice_start(m, t + 1, T);
    rows(m, x.data(), y.data(), bp, kind, row0, row1);
  });
}

}  // namespace lamina::sim::detail
