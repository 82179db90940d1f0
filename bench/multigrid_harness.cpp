// The multigrid's iterations on the implicit step's system, away from the step's dynamics
// (issue 48): the physical liver's system at rest for dt (default 16.7 ms) at each skin size,
// solved by conjugate gradients from zero, preconditioned by the V-cycle, on a smooth right side
// (the force of a dent under the tool: A u, u a Gaussian bump 20 mm wide) and a random one, to
// 1e-3 and 1e-8 of it. Prints one line per size: unknowns by level, operator complexity, setup,
// iterations, time an iteration. Usage: multigrid_harness [--dt S] [--coarsest N] [--smoothed]
// SKIN... (--smoothed: Vanek's smoothed aggregation instead of the steps' plain one). Also
// times one V-cycle below the finest level in Eigen's double CSR and in float blocks.
// --geometric RATIO: also the geometric coarse space (a model of SKIN / RATIO skin vertices).
// --grid F: also a grid's coarse level (build_multigrid's grid_mm: F x the mean tetrahedron
// edge), the aggregation below it.
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <omp.h>

#include <chrono>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "lamina/geometry/make_phantom.h"
#include "lamina/io/scene.h"
#include "lamina/io/scene_model.h"
#include "lamina/model/build_model.h"
#include "lamina/model/embed_surface.h"
#include "lamina/sim/simulation.h"
#include "sim/block_rows.h"
#include "sim/multigrid.h"
#include "sim/preconditioner.h"
#include "sim/solver.h"

namespace {

using namespace lamina;
using Clock = std::chrono::steady_clock;

double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// PCG from zero preconditioned by one V-cycle, to |r| <= tol |b|; returns the iterations.
int pcg(const sim::detail::SparseRows& A, sim::detail::Multigrid& mg, const Eigen::VectorXd& b,
        double tol, int cap) {
  return sim::detail::pcg_iterations(A, b, tol, cap,
                                     [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) {
                                       mg.levels[0].b = r;
                                       sim::detail::v_cycle(mg, 0);
                                       z = mg.levels[0].x;
                                     });
}

// STREAM's triad on every thread, the best of five (as `lamina bench` measures it), GB/s.
double triad_gb_s() {
  const std::ptrdiff_t n = 1 << 25;
  std::vector<double> a(static_cast<size_t>(n), 0.0), b(a.size(), 1.0), c(a.size(), 2.0);
  double best = 0.0;
  for (int r = 0; r < 5; ++r) {
    const auto t0 = Clock::now();
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t i = 0; i < n; ++i) a[i] = b[i] + 3.0 * c[i];
    best = std::max(best, 24.0 * static_cast<double>(n) / since(t0) / 1e9);
  }
  return best;
}

// Bytes one CG iteration of the step streams at the least: three products of the finest level
// (CG's and the V-cycle's two: the tetrahedra's float 3x3 blocks when assembled, else the
// double CSR), two products and the two transfers of each coarse level in float blocks (values,
// a column a block, row offsets), the coarsest factor's two triangular solves, every vector read
// or written once a product.
double bytes_an_iteration(const sim::detail::Solver& s, const sim::detail::Multigrid& mg) {
  const auto csr = [](const sim::detail::SparseRows& M) {
    return 12.0 * static_cast<double>(M.nonZeros()) + 4.0 * static_cast<double>(M.rows()) +
           8.0 * static_cast<double>(M.rows() + M.cols());
  };
  const sim::detail::TetAssembly& a = s.tets.assembly;
  const double fine = a.on ? 40.0 * static_cast<double>(a.column.size()) +
                                 4.0 * static_cast<double>(a.offsets.size()) +
                                 16.0 * static_cast<double>(mg.levels[0].A.rows())
                           : csr(mg.levels[0].A);
  double bytes = 3.0 * fine;
  const auto blocks = [](const sim::detail::FloatBlocks& M) {
    return 4.0 * static_cast<double>(M.value.size() + M.column.size() + M.offsets.size()) +
           8.0 * static_cast<double>(M.block_rows * M.br + M.block_cols * M.bc);
  };
  for (size_t l = 0; l + 1 < mg.levels.size(); ++l) {
    if (l > 0) bytes += 2.0 * blocks(mg.levels[l].A_blocks);
    bytes += blocks(mg.levels[l].P_blocks) + blocks(mg.levels[l].R_blocks);
  }
  bytes += 2.0 * 12.0 * static_cast<double>(mg.coarsest.matrixL().nestedExpression().nonZeros());
  return bytes;
}

// The cycle below the finest level as the steps took it before issue 48's item 3: Eigen's
// double CSR products on one thread, for the ratio against the float blocks in the same run.
void v_cycle_csr(sim::detail::Multigrid& mg, size_t from) {
  sim::detail::MultigridLevel& level = mg.levels[from];
  if (from + 1 == mg.levels.size()) {
    level.x = mg.coarsest.solve(level.b);
    return;
  }
  sim::detail::MultigridLevel& next = mg.levels[from + 1];
  level.x = level.omega * level.inv_diag.cwiseProduct(level.b);
  level.r.noalias() = level.A * level.x;
  level.r = level.b - level.r;
  next.b.noalias() = level.R * level.r;
  v_cycle_csr(mg, from + 1);
  level.x.noalias() += level.P * next.x;
  level.r.noalias() = level.A * level.x;
  level.x += level.omega * level.inv_diag.cwiseProduct(level.b - level.r);
}

// What one V-cycle costs below the finest level's products (the restriction of its residual,
// the coarse levels, the prolongation back), ms, the best of five runs of 20, and the result:
// Eigen's double CSR (`csr`) or the float blocks on mg.threads.
double below_finest_ms(sim::detail::Multigrid& mg, const Eigen::VectorXd& r, bool csr,
                       Eigen::VectorXd& z) {
  sim::detail::MultigridLevel& fine = mg.levels[0];
  double best = 1e30;
  for (int run = 0; run < 5; ++run) {
    const auto t0 = Clock::now();
    for (int k = 0; k < 20; ++k) {
      z.setZero(r.size());
      if (csr) {
        mg.levels[1].b.noalias() = fine.R * r;
        v_cycle_csr(mg, 1);
        z.noalias() += fine.P * mg.levels[1].x;
      } else {
        sim::detail::multiply(fine.R_blocks, r, mg.levels[1].b, mg.threads);
        sim::detail::v_cycle(mg, 1);
        sim::detail::multiply(fine.P_blocks, mg.levels[1].x, z, mg.threads,
                              sim::detail::BlockProduct::kAdd);
      }
    }
    best = std::min(best, 1e3 * since(t0) / 20);
  }
  return best;
}

// The other coarse space issue 48 names: geometric, the first coarse level a coarser model of
// the same organ (the reference paper's multi-scale idea; Georgii & Westermann 2005). Each fine
// node is embedded in the coarse model's rest tetrahedra (model::embed_surface's barycentric
// weights: linear interpolation, so the rigid motions are in the coarse space); P interpolates
// the coarse nodes' motion to the fine nodes, the coarse operator is P^T A P, and below it the
// same aggregation as the steps'. One damped-Jacobi sweep on the fine level before and after,
// as the V-cycle's.
struct Geometric {
  sim::detail::SparseRows P, R;
  sim::detail::Multigrid below;
  Eigen::VectorXd inv_diag, res;
  double omega = 0.0;
  int32_t coarse_nodes = 0;
};

void build_geometric(const sim::detail::SparseRows& A, const Eigen::MatrixX3d& fine_points,
                     model::BuildOptions options, int coarse_skin, Geometric& g) {
  options.skin_vertices = coarse_skin;
  const Model coarse = model::build_model(geometry::make_phantom(), options).model;
  Eigen::MatrixX3i one(1, 3);
  one << 0, 1, 2;
  const EmbeddedSurface e =
      model::embed_surface(coarse, fine_points, one, "fine nodes", SurfaceRole::kStructure);
  std::vector<int32_t> column(static_cast<size_t>(coarse.node_count()), -1);
  std::vector<Eigen::Triplet<double>> t;
  std::vector<Eigen::Vector3d> points;
  for (Eigen::Index i = 0; i < fine_points.rows(); ++i)
    for (int c = 0; c < 4; ++c) {
      const int32_t node = e.corners(i, c);
      if (column[node] < 0) {
        column[node] = static_cast<int32_t>(points.size());
        points.emplace_back(coarse.X.row(node).transpose());
      }
      for (int d = 0; d < 3; ++d) t.emplace_back(3 * i + d, 3 * column[node] + d, e.weights(i, c));
    }
  g.coarse_nodes = static_cast<int32_t>(points.size());
  g.P.resize(A.rows(), 3 * g.coarse_nodes);
  g.P.setFromTriplets(t.begin(), t.end());
  g.R = g.P.transpose();
  const sim::detail::SparseRows AP = A * g.P;
  const sim::detail::SparseRows coarse_A = g.R * AP;
  Eigen::MatrixX3d coarse_points(g.coarse_nodes, 3);
  for (int32_t k = 0; k < g.coarse_nodes; ++k) coarse_points.row(k) = points[k].transpose();
  sim::detail::build_multigrid(coarse_A, coarse_points, g.below);
  g.below.threads = omp_get_max_threads();
  g.inv_diag = A.diagonal().cwiseInverse();
  g.omega = 4.0 / (3.0 * sim::detail::jacobi_spectral_radius(A, g.inv_diag));
}

int pcg_geometric(const sim::detail::SparseRows& A, Geometric& g, const Eigen::VectorXd& b,
                  double tol, int cap) {
  return sim::detail::pcg_iterations(A, b, tol, cap,
                                     [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) {
                                       z = g.omega * g.inv_diag.cwiseProduct(r);
                                       g.res = r - A * z;
                                       g.below.levels[0].b = g.R * g.res;
                                       sim::detail::v_cycle(g.below, 0);
                                       z += g.P * g.below.levels[0].x;
                                       g.res = r - A * z;
                                       z += g.omega * g.inv_diag.cwiseProduct(g.res);
                                     });
}

}  // namespace

int run(int argc, char** argv) {
  double dt = 1.0 / 60.0;
  int64_t coarsest = 1500;
  bool smoothed = false;
  int geometric = 0;  // > 0: also the geometric coarse space, a model of skin / geometric
  double grid = 0.0;  // > 0: also a grid's coarse level, spacing grid x the mean edge
  std::vector<int> sizes;
  for (int k = 1; k < argc; ++k) {
    const std::string a = argv[k];
    if (a == "--dt" && k + 1 < argc)
      dt = std::atof(argv[++k]);
    else if (a == "--smoothed")
      smoothed = true;
    else if (a == "--coarsest" && k + 1 < argc)
      coarsest = std::atoll(argv[++k]);
    else if (a == "--geometric" && k + 1 < argc)
      geometric = std::atoi(argv[++k]);
    else if (a == "--grid" && k + 1 < argc)
      grid = std::atof(argv[++k]);
    else if (!a.empty() && a.find_first_not_of("0123456789") == std::string::npos)
      sizes.push_back(std::atoi(a.c_str()));
    else {
      fmt::print(stderr,
                 "usage: multigrid_harness [--dt S] [--coarsest N] [--smoothed] [--geometric "
                 "RATIO] [--grid F] [SKIN...]{}\n",
                 a == "--help" || a == "-h" ? "" : fmt::format(" (not understood: {})", a));
      return a == "--help" || a == "-h" ? 0 : 2;
    }
  }
  if (sizes.empty()) sizes = {1284, 5000, 10000, 20000};
  fmt::print("dt {:.4g} s, coarsest <= {} unknowns, {} aggregation\n", dt, coarsest,
             smoothed ? "smoothed" : "plain");
  const double bandwidth = triad_gb_s();
  fmt::print(
      "STREAM triad {:.1f} GB/s; MB/it: what a step's CG iteration streams at the least, "
      "floor = that at the triad's bandwidth\n",
      bandwidth);
  fmt::print(
      "below: one V-cycle below the finest level's products (restriction, coarse levels, "
      "prolongation), ms: Eigen's double CSR on one thread / float blocks on {} threads\n",
      omp_get_max_threads());
  fmt::print("{:>6} {:>7} {:>28} {:>5} {:>7} {:>6} {:>6} {:>6} {:>6} {:>8} {:>7} {:>9} {:>15}\n",
             "skin", "nodes", "unknowns by level", "opc", "setup", "sm-3", "sm-8", "rnd-3", "rnd-8",
             "ms/it", "MB/it", "floor ms", "below csr/blk");
  for (int skin : sizes) {
    io::Scene scene;
    scene.build.skin_vertices = skin;
    scene.solver.dt_s = dt;
    scene.solver.preconditioner = sim::Preconditioner::kMultigrid;
    io::SceneModel built{model::build_model(geometry::make_phantom(), scene.build).model,
                         "phantom"};
    const io::ReadyScene ready = io::make_ready_scene(scene, std::move(built));
    sim::Simulation s = io::make_scene_simulation(ready);
    sim::prepare_solver(s);
    sim::detail::MultigridPreconditioner& p = *s.solver().multigrid;
    const sim::detail::SparseRows A = sim::detail::to_sparse(p.system);
    sim::detail::Multigrid mg;
    const Eigen::Index rows = static_cast<Eigen::Index>(p.nodes.size());
    Eigen::MatrixX3d points(rows, 3);
    for (Eigen::Index q = 0; q < rows; ++q) points.row(q) = ready.model->X.row(p.nodes[q]);
    const auto t0 = Clock::now();
    sim::detail::build_multigrid(A, points, mg, coarsest, smoothed);
    mg.threads = omp_get_max_threads();
    const double setup = since(t0);
    // A dent: a Gaussian bump of the positions along y around the most anterior node.
    Eigen::Index front = 0;
    points.col(1).minCoeff(&front);
    Eigen::VectorXd u = Eigen::VectorXd::Zero(3 * rows), noise(3 * rows);
    for (Eigen::Index q = 0; q < rows; ++q) {
      const double d2 = (points.row(q) - points.row(front)).squaredNorm();
      u[3 * q + 1] = std::exp(-d2 / (2 * 20.0 * 20.0));
    }
    std::mt19937 rng(7);
    std::normal_distribution<double> normal;
    for (Eigen::Index k = 0; k < noise.size(); ++k) noise[k] = normal(rng);
    const Eigen::VectorXd smooth = A * u;
    const auto t1 = Clock::now();
    const int s3 = pcg(A, mg, smooth, 1e-3, 500);
    const int s8 = pcg(A, mg, smooth, 1e-8, 500);
    const int r3 = pcg(A, mg, noise, 1e-3, 500);
    const int r8 = pcg(A, mg, noise, 1e-8, 500);
    const double per_it = 1e3 * since(t1) / (s3 + s8 + r3 + r8);
    const double mb = bytes_an_iteration(s.solver(), p.mg) / 1e6;
    Eigen::VectorXd z_csr, z_blocks;
    double csr_ms = 0.0, blocks_ms = 0.0;
    if (mg.levels.size() > 1) {
      csr_ms = below_finest_ms(mg, noise, true, z_csr);
      blocks_ms = below_finest_ms(mg, noise, false, z_blocks);
      // The same operator in single precision: a check that the timing compares like with like.
      const double differ = (z_csr - z_blocks).norm() / z_csr.norm();
      if (!(differ < 1e-4))
        fmt::print(stderr, "the float blocks' cycle differs by {:.2g}\n", differ);
    }
    fmt::print(
        "{:>6} {:>7} {:>28} {:>5.2f} {:>7.2f} {:>6} {:>6} {:>6} {:>6} {:>8.2f} {:>7.1f} {:>9.2f} "
        "{:>15}\n",
        skin, ready.model->node_count(), fmt::format("{}", fmt::join(mg.shape.unknowns, ">")),
        mg.shape.operator_complexity, setup, s3, s8, r3, r8, per_it, mb, mb / 1e3 / bandwidth * 1e3,
        fmt::format("{:.2f}/{:.2f}", csr_ms, blocks_ms));
    if (grid > 0.0) {
      double edges = 0.0;
      int64_t count = 0;
      const Model& m = *ready.model;
      for (Eigen::Index t = 0; t < m.tets.T.rows(); ++t)
        for (int a = 0; a < 4; ++a)
          for (int b = a + 1; b < 4; ++b, ++count)
            edges += (m.X.row(m.tets.T(t, a)) - m.X.row(m.tets.T(t, b))).norm();
      const double spacing = grid * edges / static_cast<double>(count);
      sim::detail::Multigrid gm;
      const auto t2 = Clock::now();
      sim::detail::build_multigrid(A, points, gm, coarsest, smoothed, spacing);
      gm.threads = omp_get_max_threads();
      const double g_setup = since(t2);
      const int gs3 = pcg(A, gm, smooth, 1e-3, 500);
      const int gs8 = pcg(A, gm, smooth, 1e-8, 500);
      const int gr3 = pcg(A, gm, noise, 1e-3, 500);
      const int gr8 = pcg(A, gm, noise, 1e-8, 500);
      fmt::print(
          "{:>6} {:>7} {:>28} {:>5.2f} {:>7.2f} {:>6} {:>6} {:>6} {:>6}   grid: {:.2f} mm "
          "spacing\n",
          "", "", fmt::format("{}", fmt::join(gm.shape.unknowns, ">")),
          gm.shape.operator_complexity, g_setup, gs3, gs8, gr3, gr8, spacing);
    }
    if (geometric > 0) {
      Geometric g;
      const auto t2 = Clock::now();
      build_geometric(A, points, scene.build, skin / geometric, g);
      const double g_setup = since(t2);
      const int gs3 = pcg_geometric(A, g, smooth, 1e-3, 500);
      const int gs8 = pcg_geometric(A, g, smooth, 1e-8, 500);
      const int gr3 = pcg_geometric(A, g, noise, 1e-3, 500);
      const int gr8 = pcg_geometric(A, g, noise, 1e-8, 500);
      std::vector<int64_t> unknowns{A.rows()};
      for (int64_t u : g.below.shape.unknowns) unknowns.push_back(u);
      const double opc = 1.0 + g.below.shape.operator_complexity *
                                   static_cast<double>(g.below.levels[0].A.nonZeros()) /
                                   static_cast<double>(A.nonZeros());
      fmt::print(
          "{:>6} {:>7} {:>28} {:>5.2f} {:>7.2f} {:>6} {:>6} {:>6} {:>6}   geometric: a "
          "{}-skin-vertex model's {} nodes\n",
          "", "", fmt::format("{}", fmt::join(unknowns, ">")), opc, g_setup, gs3, gs8, gr3, gr8,
          skin / geometric, g.coarse_nodes);
    }
    std::fflush(stdout);
  }
  return 0;
}

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {  // a skin size the build refuses, say
    fmt::print(stderr, "multigrid_harness: {}\n", e.what());
    return 2;
  }
}
