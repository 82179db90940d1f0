// Aggregation multigrid (multigrid.h): the hierarchy's setup and the V-cycle.
#include "multigrid.h"

#include <omp.h>

#include <Eigen/Geometry>
#include <Eigen/QR>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <utility>

#include "lamina/core/clock.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"

namespace lamina::sim::detail {
namespace {

// The nodes of one level: each owns a contiguous range of unknowns.
struct LevelNodes {
  std::vector<int32_t> offsets;  ///< #nodes + 1
  std::vector<int32_t> node_of;  ///< per unknown
  int32_t count() const { return static_cast<int32_t>(offsets.size()) - 1; }
};

// Strong neighbours of each node (CSR): |A_IJ|_F^2 >= theta^2 |A_II|_F |A_JJ|_F over the 3x3 (or
// r x r) blocks. A weak link (a sliver tetrahedron's, a soft spring's) does not pull two nodes
// into one aggregate whose motion the coarse level would then misrepresent.
void strong_neighbours(const SparseRows& A, const LevelNodes& nodes, double theta,
                       std::vector<int32_t>& offsets, std::vector<int32_t>& adj) {
  const int32_t n = nodes.count();
  std::vector<double> self(static_cast<size_t>(n), 0.0), acc(static_cast<size_t>(n), 0.0);
  std::vector<int32_t> touched;
  for (Eigen::Index d = 0; d < A.outerSize(); ++d)
    for (SparseRows::InnerIterator it(A, d); it; ++it)
      if (nodes.node_of[it.col()] == nodes.node_of[d])
        self[nodes.node_of[d]] += it.value() * it.value();
  for (double& v : self) v = std::sqrt(v);
  offsets.assign(1, 0);
  adj.clear();
  for (int32_t i = 0; i < n; ++i) {
    touched.clear();
    for (int32_t d = nodes.offsets[i]; d < nodes.offsets[i + 1]; ++d)
      for (SparseRows::InnerIterator it(A, d); it; ++it) {
        const int32_t j = nodes.node_of[it.col()];
        if (j == i) continue;
        if (acc[j] == 0.0) touched.push_back(j);
        acc[j] += it.value() * it.value() + 1e-300;  // stays > 0 once touched
      }
    std::sort(touched.begin(), touched.end());
    for (int32_t j : touched) {
      if (acc[j] >= theta * theta * self[i] * self[j]) adj.push_back(j);
      acc[j] = 0.0;
    }
    offsets.push_back(static_cast<int32_t>(adj.size()));
  }
}

// Vanek's three phases: a node whose neighbours are all free starts an aggregate with them; a
// node left over joins a neighbouring aggregate; what is still left groups with its free
// neighbours. Returns the aggregate of each node and sets `count`.
std::vector<int32_t> aggregate(const std::vector<int32_t>& offsets, const std::vector<int32_t>& adj,
                               int32_t& count) {
  const auto n = static_cast<int32_t>(offsets.size()) - 1;
  std::vector<int32_t> agg(static_cast<size_t>(n), -1);
  count = 0;
  for (int32_t i = 0; i < n; ++i) {
    if (agg[i] >= 0) continue;
    bool free = true;
    for (int32_t k = offsets[i]; k < offsets[i + 1] && free; ++k) free = agg[adj[k]] < 0;
    if (!free) continue;
    agg[i] = count;
    for (int32_t k = offsets[i]; k < offsets[i + 1]; ++k) agg[adj[k]] = count;
    ++count;
  }
  std::vector<int32_t> joined = agg;
  for (int32_t i = 0; i < n; ++i)
    if (agg[i] < 0)
      for (int32_t k = offsets[i]; k < offsets[i + 1]; ++k)
        if (agg[adj[k]] >= 0) {
          joined[i] = agg[adj[k]];
          break;
        }
  agg.swap(joined);
  for (int32_t i = 0; i < n; ++i) {
    if (agg[i] >= 0) continue;
    agg[i] = count;
    for (int32_t k = offsets[i]; k < offsets[i + 1]; ++k)
      if (agg[adj[k]] < 0) agg[adj[k]] = count;
    ++count;
  }
  return agg;
}

// Every coarse node's unknowns: its rigid motions, padded to six.
constexpr int kCoarseBlock = 6;

// P^T A P, with the padding's own diagonal: a padded unknown's row and column are empty, and
// it takes its node's first diagonal entry (the scale of its neighbours: a positive definite
// operator, and a smoother's weight for it that the power iteration does not see as an outlier).
SparseRows galerkin(const MultigridLevel& level, const std::vector<int32_t>& padding) {
  SparseRows coarse;
  if (!galerkin_by_blocks(level.A, level.P, level.block, kCoarseBlock, padding,
                          omp_get_max_threads(), coarse)) {
    const SparseRows AP = level.A * level.P;
    coarse = level.R * AP;
  }
  if (padding.empty()) return coarse;
  SparseRows pad(coarse.rows(), coarse.cols());
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(padding.size());
  for (int32_t k : padding) {
    const int32_t first = k - k % kCoarseBlock;
    t.emplace_back(k, k, coarse.coeff(first, first));
  }
  pad.setFromTriplets(t.begin(), t.end());
  return coarse + pad;
}

// inv_diag, omega and the workspace of a level; the float blocks of a coarse level's A.
// `weight`: omega by power iteration (15 products of A; not on the finest level of the steps'
// hierarchy, whose smoother the caller owns: 28 ms of a 213 ms build at 47,685 nodes).
void finish_level(MultigridLevel& level, bool coarse, bool weight = true) {
  if (coarse) to_float_blocks(level.A, level.block, level.block, level.A_blocks);
  level.inv_diag = level.A.diagonal().cwiseInverse();
  if (!level.inv_diag.allFinite() || (level.A.diagonal().array() <= 0.0).any())
    throw Error(ErrorKind::kInternal, "multigrid: a level's diagonal is not positive");
  level.omega = weight ? 4.0 / (3.0 * jacobi_spectral_radius(level.A, level.inv_diag)) : 0.0;
  level.b.setZero(level.A.rows());
  level.x.setZero(level.A.rows());
  level.r.setZero(level.A.rows());
}

}  // namespace

double jacobi_spectral_radius(const SparseRows& A, const Eigen::VectorXd& inv_diag) {
  Eigen::VectorXd x(A.rows()), y(A.rows());
  power_iteration_start(x);
  x.normalize();
  double rho = 0.0;
  for (int it = 0; it < 15; ++it) {
    y.noalias() = A * x;
    y = inv_diag.cwiseProduct(y);
    rho = y.norm();
    if (!(rho > 0.0)) break;
    x = y / rho;
  }
  return rho;
}

// A corner only given zero weights (a point on its cell's far face) is not made: P has no empty
// column, and the coarse operator no empty row.
Eigen::MatrixX3d grid_prolongation(const Eigen::MatrixX3d& points, double grid_mm, SparseRows& P) {
  const Eigen::RowVector3d low = points.colwise().minCoeff();
  const Eigen::RowVector3d extent = points.colwise().maxCoeff() - low;
  Eigen::Array3i cells;
  for (int d = 0; d < 3; ++d)
    cells[d] = std::max(1, static_cast<int>(std::ceil(extent[d] / grid_mm)));
  const auto corner_key = [&](const Eigen::Array3i& c) {
    return (static_cast<int64_t>(c[2]) * (cells[1] + 1) + c[1]) * (cells[0] + 1) + c[0];
  };
  std::vector<int32_t> corner_of(static_cast<size_t>(corner_key(cells)) + 1, -1);
  std::vector<Eigen::Vector3d> corners;
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(static_cast<size_t>(24 * points.rows()));
  for (Eigen::Index i = 0; i < points.rows(); ++i) {
    const Eigen::Array3d u = ((points.row(i) - low) / grid_mm).transpose().array();
    Eigen::Array3i cell;
    Eigen::Array3d f;
    for (int d = 0; d < 3; ++d) {
      cell[d] = std::clamp(static_cast<int>(std::floor(u[d])), 0, cells[d] - 1);
      f[d] = std::clamp(u[d] - cell[d], 0.0, 1.0);
    }
    for (int k = 0; k < 8; ++k) {
      const Eigen::Array3i bit((k & 1), (k >> 1) & 1, (k >> 2) & 1);
      double w = 1.0;
      for (int d = 0; d < 3; ++d) w *= bit[d] != 0 ? f[d] : 1.0 - f[d];
      if (w <= 0.0) continue;
      const Eigen::Array3i c = cell + bit;
      int32_t& column = corner_of[static_cast<size_t>(corner_key(c))];
      if (column < 0) {
        column = static_cast<int32_t>(corners.size());
        corners.emplace_back(low.transpose() + grid_mm * c.cast<double>().matrix());
      }
      for (int d = 0; d < 3; ++d) t.emplace_back(3 * i + d, 3 * column + d, w);
    }
  }
  P.resize(3 * points.rows(), 3 * static_cast<Eigen::Index>(corners.size()));
  P.setFromTriplets(t.begin(), t.end());
  Eigen::MatrixX3d out(static_cast<Eigen::Index>(corners.size()), 3);
  for (size_t k = 0; k < corners.size(); ++k)
    out.row(static_cast<Eigen::Index>(k)) = corners[k].transpose();
  return out;
}

void build_multigrid(SparseRows A, const Eigen::MatrixX3d& fine_points, Multigrid& mg,
                     int64_t coarsest_unknowns, bool smoothed, double grid_mm) {
  const auto t0 = Clock::now();
  mg.levels.clear();
  // At most 10 levels (below): no level is moved by a reallocation (0.4 s at 47,685 nodes).
  mg.levels.reserve(10);
  mg.shape = {};
  mg.levels.emplace_back();
  mg.levels[0].A = std::move(A);
  Eigen::MatrixX3d points = fine_points;
  if (grid_mm > 0.0 && mg.levels[0].A.rows() > coarsest_unknowns) {
    MultigridLevel& fine = mg.levels[0];
    finish_level(fine, false);
    points = grid_prolongation(fine_points, grid_mm, fine.P);
    fine.R = fine.P.transpose();
    to_float_blocks(fine.P, 3, 3, fine.P_blocks);
    to_float_blocks(fine.R, 3, 3, fine.R_blocks);
    MultigridLevel next;
    next.A = galerkin(fine, next.padding);
    log::debug("multigrid level 0: {} unknowns, a {:.3g} mm grid of {} corners, coarse {} nonzeros",
               fine.A.rows(), grid_mm, points.rows(), next.A.nonZeros());
    mg.levels.push_back(std::move(next));
  }
  // The near-null space on the finest level: per node, the three translations and the three
  // rotations about the origin (each aggregate's QR below recentres them).
  const auto n0 = static_cast<int32_t>(points.rows());
  Eigen::MatrixXd B = Eigen::MatrixXd::Zero(3 * n0, 6);
  LevelNodes nodes;
  nodes.offsets.resize(static_cast<size_t>(n0) + 1);
  nodes.node_of.resize(3 * static_cast<size_t>(n0));
  for (int32_t i = 0; i < n0; ++i) {
    const Eigen::Vector3d p = points.row(i).transpose();
    nodes.offsets[i] = 3 * i;
    for (int d = 0; d < 3; ++d) {
      nodes.node_of[3 * i + d] = i;
      B(3 * i + d, d) = 1.0;
      // Rotation about axis k: e_k x p, component d.
      for (int k = 0; k < 3; ++k) B(3 * i + d, 3 + k) = Eigen::Vector3d::Unit(k).cross(p)[d];
    }
  }
  nodes.offsets[n0] = 3 * n0;
  // Strength matters on the finest level (the mesh's slivers and soft links); the coarse
  // operators are denser and smoother, and a threshold there left aggregates of two or three
  // nodes (a 9,871-node liver's third level kept 43% of the second's unknowns).
  for (double theta = 0.08;; theta = 0.0) {
    MultigridLevel& level = mg.levels.back();
    finish_level(level, mg.levels.size() > 1, mg.levels.size() > 1 || !mg.caller_smooths);
    const auto real_unknowns = static_cast<int64_t>(level.A.rows() - level.padding.size());
    if (real_unknowns <= coarsest_unknowns || mg.levels.size() >= 10) break;
    std::vector<int32_t> offsets, adj;
    strong_neighbours(level.A, nodes, theta, offsets, adj);
    int32_t count = 0;
    const std::vector<int32_t> agg = aggregate(offsets, adj, count);
    // Each aggregate's unknowns and the prolongation: an orthonormal basis of its
    // rigid motions (Q of a rank-revealing QR; fewer than six when the aggregate is too small
    // or too flat to carry them all), the coarse near-null space R = Q^T B.
    std::vector<std::vector<int32_t>> members(static_cast<size_t>(count));
    for (int32_t i = 0; i < nodes.count(); ++i) members[agg[i]].push_back(i);
    std::vector<Eigen::Triplet<double>> t;
    t.reserve(static_cast<size_t>(6 * level.A.rows()));
    LevelNodes coarse;
    coarse.offsets.assign(1, 0);
    std::vector<Eigen::MatrixXd> coarse_b(static_cast<size_t>(count));
    std::vector<int32_t> dofs, padding;
    int64_t real = 0;
    for (int32_t a = 0; a < count; ++a) {
      dofs.clear();
      for (int32_t i : members[a])
        for (int32_t d = nodes.offsets[i]; d < nodes.offsets[i + 1]; ++d) dofs.push_back(d);
      Eigen::MatrixXd local(static_cast<Eigen::Index>(dofs.size()), 6);
      for (size_t r = 0; r < dofs.size(); ++r)
        local.row(static_cast<Eigen::Index>(r)) = B.row(dofs[r]);
      Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(local);
      qr.setThreshold(1e-9);
      const auto rank = static_cast<int32_t>(qr.rank());
      const Eigen::MatrixXd Q = qr.householderQ() * Eigen::MatrixXd::Identity(local.rows(), rank);
      coarse_b[a] = Q.transpose() * local;
      const int32_t first = coarse.offsets.back();
      for (size_t r = 0; r < dofs.size(); ++r)
        for (int32_t c = 0; c < rank; ++c)
          t.emplace_back(dofs[r], first + c, Q(static_cast<Eigen::Index>(r), c));
      coarse.offsets.push_back(first + kCoarseBlock);
      for (int32_t c = 0; c < kCoarseBlock; ++c) coarse.node_of.push_back(a);
      for (int32_t c = rank; c < kCoarseBlock; ++c) padding.push_back(first + c);
      real += rank;
    }
    const int32_t unknowns = coarse.offsets.back();
    // Coarsening that keeps more than half the unknowns costs more than it saves: this level is
    // then the coarsest.
    if (2 * real > real_unknowns) break;
    // Plain aggregation: P is the tentative prolongation itself. Smoothing it by one Jacobi step
    // (Vanek's smoothed aggregation) took the same CG iterations on the 22k- and 48k-node livers
    // at 10 ms (15.5 and 53.9 a step, against 14.2 and 41.7) but made the second level's
    // operator six times denser: 224 against 103 ms a step at 22k, 1,444 against 497 ms at 48k,
    // and 8.2 against 1.1 s to build (docs/benchmarks.md).
    level.P.resize(level.A.rows(), unknowns);
    level.P.setFromTriplets(t.begin(), t.end());
    if (smoothed) {  // issue 48's comparison (multigrid_harness): flatter, twice as dear
      const SparseRows AP = level.A * level.P;
      const SparseRows step = (level.omega * level.inv_diag).asDiagonal() * AP;
      level.P = SparseRows(level.P - step);
      level.P.prune(0.0);
    }
    level.R = level.P.transpose();
    to_float_blocks(level.P, level.block, kCoarseBlock, level.P_blocks);
    to_float_blocks(level.R, kCoarseBlock, level.block, level.R_blocks);
    const double t_aggregate = seconds_since(t0);
    MultigridLevel next;
    next.block = kCoarseBlock;
    next.padding = std::move(padding);
    next.A = galerkin(level, next.padding);
    log::debug(
        "multigrid level {}: {} unknowns, {} aggregates, P {} nonzeros, coarse {} nonzeros; "
        "aggregated at {:.2f} s, Galerkin at {:.2f} s",
        mg.levels.size() - 1, level.A.rows(), count, level.P.nonZeros(), next.A.nonZeros(),
        t_aggregate, seconds_since(t0));
    B.setZero(unknowns, 6);
    for (int32_t a = 0; a < count; ++a)
      B.middleRows(coarse.offsets[a], coarse_b[a].rows()) = coarse_b[a];
    nodes = std::move(coarse);
    mg.levels.push_back(std::move(next));
  }
  mg.coarsest.compute(Eigen::SparseMatrix<double>(mg.levels.back().A));
  if (mg.coarsest.info() != Eigen::Success)
    throw Error(ErrorKind::kInternal, "multigrid: the coarsest level did not factor");
  const double fine_nonzeros = static_cast<double>(mg.levels[0].A.nonZeros());
  for (const MultigridLevel& level : mg.levels) {
    mg.shape.unknowns.push_back(level.A.rows() - static_cast<int64_t>(level.padding.size()));
    mg.shape.nonzeros.push_back(level.A.nonZeros());
    mg.shape.operator_complexity += static_cast<double>(level.A.nonZeros()) / fine_nonzeros;
  }
  mg.shape.setup_s = seconds_since(t0);
}

void rebuild_operators(SparseRows A, Multigrid& mg) {
  const auto t0 = Clock::now();
  if (mg.levels.empty() || A.rows() != mg.levels[0].A.rows())
    throw Error(ErrorKind::kInternal, "multigrid: operators rebuilt on other unknowns");
  mg.levels[0].A = std::move(A);
  for (size_t l = 0; l < mg.levels.size(); ++l) {
    MultigridLevel& level = mg.levels[l];
    finish_level(level, l > 0, l > 0 || !mg.caller_smooths);
    if (l + 1 == mg.levels.size()) break;
    mg.levels[l + 1].A = galerkin(level, mg.levels[l + 1].padding);
  }
  const Eigen::SparseMatrix<double> coarsest(mg.levels.back().A);
  if (coarsest.nonZeros() == mg.shape.nonzeros.back())
    mg.coarsest.factorize(coarsest);  // the same pattern: its ordering and analysis stay
  else
    mg.coarsest.compute(coarsest);
  if (mg.coarsest.info() != Eigen::Success)
    throw Error(ErrorKind::kInternal, "multigrid: the coarsest level did not factor");
  for (size_t l = 0; l < mg.levels.size(); ++l) mg.shape.nonzeros[l] = mg.levels[l].A.nonZeros();
  mg.shape.setup_s = seconds_since(t0);
}

void v_cycle(Multigrid& mg, size_t from) {
  if (from == 0 && mg.caller_smooths)
    throw Error(ErrorKind::kInternal, "multigrid: a cycle from a finest level it does not smooth");
  MultigridLevel& level = mg.levels[from];
  if (from + 1 == mg.levels.size()) {
    level.x = mg.coarsest.solve(level.b);
    return;
  }
  MultigridLevel& next = mg.levels[from + 1];
  const double w = level.omega;
  // r = b - A x: the coarse levels' float blocks; the finest level's own matrix when a caller
  // cycles from it (the slowest vibration's LOBPCG, the harness).
  const auto residual = [&] {
    if (!level.A_blocks.empty()) {
      multiply(level.A_blocks, level.x, level.r, mg.threads, BlockProduct::kResidual, &level.b);
    } else {
      level.r.noalias() = level.A * level.x;
      level.r = level.b - level.r;
    }
  };
  level.x = w * level.inv_diag.cwiseProduct(level.b);
  residual();
  multiply(level.R_blocks, level.r, next.b, mg.threads);
  v_cycle(mg, from + 1);
  multiply(level.P_blocks, next.x, level.x, mg.threads, BlockProduct::kAdd);
  residual();
  level.x += w * level.inv_diag.cwiseProduct(level.r);
}

}  // namespace lamina::sim::detail
