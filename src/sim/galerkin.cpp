// The multigrid's coarse operator P^T A P block by block (multigrid.h: galerkin_by_blocks).
//
// Plain aggregation's prolongation puts each fine node's rows in one coarse node's columns, so
// the coarse block between aggregates a and b is the sum over fine nodes i of a of
// P_i^T (sum over A's neighbours j of i in b of A_ij P_j). Summed so, in small dense blocks,
// it takes a tenth of the flops and none of the index merging of Eigen's two general sparse
// products (A P, then P^T (A P)), which were three quarters of the hierarchy's setup: 0.78 of
// 1.06 s for the finest level at 101,785 nodes (docs/benchmarks.md).
#include <omp.h>

#include <algorithm>
#include <vector>

#include "multigrid.h"

namespace lamina::sim::detail {

bool galerkin_by_blocks(const SparseRows& A, const SparseRows& P, int fine_block, int coarse_block,
                        const std::vector<int32_t>& padding, int threads, SparseRows& out) {
  const int bf = fine_block, bc = coarse_block;
  const auto fine = static_cast<int32_t>(A.rows() / bf);
  const auto coarse = static_cast<int32_t>(P.cols() / bc);
  if (A.rows() % bf != 0 || P.cols() % bc != 0 || P.rows() != A.rows()) return false;
  // Each fine node's coarse node and its rows of P, dense (bf x bc, row-major).
  std::vector<int32_t> agg(static_cast<size_t>(fine), -1);
  std::vector<double> dense(static_cast<size_t>(fine) * bf * bc, 0.0);
  for (int32_t i = 0; i < fine; ++i)
    for (int d = 0; d < bf; ++d)
      for (SparseRows::InnerIterator it(P, static_cast<Eigen::Index>(bf) * i + d); it; ++it) {
        const auto a = static_cast<int32_t>(it.col() / bc);
        if (agg[i] < 0) agg[i] = a;
        if (agg[i] != a) return false;  // a smoothed prolongation: Eigen's products
        dense[(static_cast<size_t>(i) * bf + d) * bc + it.col() % bc] = it.value();
      }
  std::vector<int32_t> offsets(static_cast<size_t>(coarse) + 1, 0), members(fine);
  for (int32_t i = 0; i < fine; ++i)
    if (agg[i] >= 0) ++offsets[agg[i] + 1];
  for (int32_t a = 0; a < coarse; ++a) offsets[a + 1] += offsets[a];
  {
    std::vector<int32_t> at(offsets.begin(), offsets.end() - 1);
    for (int32_t i = 0; i < fine; ++i)
      if (agg[i] >= 0) members[at[agg[i]]++] = i;
  }
  std::vector<uint8_t> padded(static_cast<size_t>(coarse) * bc, 0);
  for (int32_t k : padding) padded[static_cast<size_t>(k)] = 1;

  // Per coarse row a: its block columns (ascending) and their bc x bc blocks.
  std::vector<std::vector<int32_t>> columns(static_cast<size_t>(coarse));
  std::vector<std::vector<double>> blocks(static_cast<size_t>(coarse));
#pragma omp parallel num_threads(std::max(threads, 1))
  {
    std::vector<int32_t> slot(static_cast<size_t>(coarse), -1), row_slot(slot), touched, row;
    std::vector<double> s, c;  // S_ib (bf x bc each), then row a's blocks
#pragma omp for schedule(dynamic, 64)
    for (int32_t a = 0; a < coarse; ++a) {
      row.clear();
      c.clear();
      for (int32_t m = offsets[a]; m < offsets[a + 1]; ++m) {
        const int32_t i = members[m];
        touched.clear();
        s.clear();
        for (int d = 0; d < bf; ++d)
          for (SparseRows::InnerIterator it(A, static_cast<Eigen::Index>(bf) * i + d); it; ++it) {
            const auto j = static_cast<int32_t>(it.col() / bf);
            const int32_t b = agg[j];
            if (b < 0) continue;
            if (slot[b] < 0) {
              slot[b] = static_cast<int32_t>(touched.size());
              touched.push_back(b);
              s.resize(s.size() + static_cast<size_t>(bf) * bc, 0.0);
            }
            double* sib = s.data() + static_cast<size_t>(slot[b]) * bf * bc + d * bc;
            const double* pj = dense.data() + (static_cast<size_t>(j) * bf + it.col() % bf) * bc;
            for (int q = 0; q < bc; ++q) sib[q] += it.value() * pj[q];
          }
        const double* pi = dense.data() + static_cast<size_t>(i) * bf * bc;
        for (size_t t = 0; t < touched.size(); ++t) {
          const int32_t b = touched[t];
          slot[b] = -1;
          if (row_slot[b] < 0) {
            row_slot[b] = static_cast<int32_t>(row.size());
            row.push_back(b);
            c.resize(c.size() + static_cast<size_t>(bc) * bc, 0.0);
          }
          double* cab = c.data() + static_cast<size_t>(row_slot[b]) * bc * bc;
          const double* sib = s.data() + t * bf * bc;
          for (int p = 0; p < bc; ++p)
            for (int d = 0; d < bf; ++d) {
              const double w = pi[d * bc + p];
              if (w == 0.0) continue;
              for (int q = 0; q < bc; ++q) cab[p * bc + q] += w * sib[d * bc + q];
            }
        }
      }
      // Ascending block columns, as a sparse row's.
      std::vector<int32_t> order(row.size());
      for (size_t k = 0; k < order.size(); ++k) order[k] = static_cast<int32_t>(k);
      std::sort(order.begin(), order.end(), [&](int32_t x, int32_t y) { return row[x] < row[y]; });
      std::vector<int32_t>& cols = columns[a];
      std::vector<double>& vals = blocks[a];
      cols.resize(row.size());
      vals.resize(c.size());
      for (size_t k = 0; k < order.size(); ++k) {
        cols[k] = row[order[k]];
        std::copy_n(c.data() + static_cast<size_t>(order[k]) * bc * bc, bc * bc,
                    vals.data() + k * bc * bc);
        row_slot[row[order[k]]] = -1;
      }
    }
  }

  // The sparse rows: every entry of every block but a padded row's or column's (the padding has
  // no motion: P's column is zero there, and Eigen's product leaves it empty too).
  out.resize(static_cast<Eigen::Index>(coarse) * bc, static_cast<Eigen::Index>(coarse) * bc);
  std::vector<int64_t> row_start(static_cast<size_t>(coarse) * bc + 1, 0);
  for (int32_t a = 0; a < coarse; ++a) {
    int64_t live = 0;
    for (int32_t b : columns[a])
      for (int q = 0; q < bc; ++q) live += padded[static_cast<size_t>(b) * bc + q] ? 0 : 1;
    for (int p = 0; p < bc; ++p) {
      const size_t r = static_cast<size_t>(a) * bc + p;
      row_start[r + 1] = row_start[r] + (padded[r] ? 0 : live);
    }
  }
  out.resizeNonZeros(static_cast<Eigen::Index>(row_start.back()));
  int* outer = out.outerIndexPtr();
  int* inner = out.innerIndexPtr();
  double* value = out.valuePtr();
  for (size_t r = 0; r < row_start.size(); ++r) outer[r] = static_cast<int>(row_start[r]);
#pragma omp parallel for num_threads(std::max(threads, 1)) schedule(dynamic, 64)
  for (int32_t a = 0; a < coarse; ++a)
    for (int p = 0; p < bc; ++p) {
      const size_t r = static_cast<size_t>(a) * bc + p;
      if (padded[r]) continue;
      int64_t k = row_start[r];
      for (size_t blk = 0; blk < columns[a].size(); ++blk)
        for (int q = 0; q < bc; ++q) {
          const size_t col = static_cast<size_t>(columns[a][blk]) * bc + q;
          if (padded[col]) continue;
          inner[k] = static_cast<int>(col);
          value[k] = blocks[a][blk * bc * bc + p * bc + q];
          ++k;
        }
    }

  return true;
}

}  // namespace lamina::sim::detail
