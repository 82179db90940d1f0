// Implicit Euler's spring products in SIMD lanes (src/sim/spring_lanes_product.h), on the paper's
// network (springs along layer edges and links): the product is the stretched springs' exact
// derivative, equals the node-by-node product over the CSR, does not depend on the thread
// count, and implicit Euler with it settles where explicit Euler does.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <map>
#include <random>

#include "lamina/geometry/make_phantom.h"
#include "lamina/interact/tools.h"
#include "lamina/model/build_model.h"
#include "lamina/sim/simulation.h"
#include "sim/spring_lanes_product.h"  // white box: the lanes and the CSR product side by side
#include "support/random_rows.h"
#include "support/tet_phantom.h"

namespace {

using namespace lamina;

const Model& links_model(int32_t skin_vertices) {
  static std::map<int32_t, Model> cache;
  auto it = cache.find(skin_vertices);
  if (it == cache.end())
    it = cache
             .emplace(skin_vertices,
                      model::build_model(
                          geometry::make_phantom({.spacing_mm = {2, 2, 2}}),
                          {.structure = model::Structure::kLinks, .skin_vertices = skin_vertices})
                          .model)
             .first;
  return it->second;
}

// The organ stretched by `factor` about its centre: every spring longer than at rest.
Eigen::MatrixX3d stretched(const Model& m, double factor) {
  const Eigen::RowVector3d centre = m.X.colwise().mean();
  return (m.X.rowwise() - centre) * factor + centre.replicate(m.node_count(), 1);
}

// An implicit simulation linearised at x (one step from there, no load).
sim::Simulation linearised_at(const Model& m, const Eigen::MatrixX3d& x,
                              const sim::Material& material = {}) {
  sim::Simulation s =
      sim::make_simulation(m, material, {.integrator = sim::Integrator::kImplicitEuler});
  s.x = x;
  sim::step(s);
  return s;
}

// The springs' K p and diagonal per node through for_spring_products (lanes where they apply).
struct Rows {
  Eigen::MatrixX3d k, d;
};
Rows lane_rows(sim::Simulation& sim, const Eigen::MatrixX3d& p, int threads) {
  sim::detail::Solver& s = sim.solver();
  Rows r{Eigen::MatrixX3d::Zero(p.rows(), 3), Eigen::MatrixX3d::Zero(p.rows(), 3)};
  sim::detail::Partials part;
  sim::detail::for_spring_products<true>(
      s, p, threads, part, [&](int32_t i, const double* k, const double* d, sim::detail::Partial&) {
        r.k.row(i) << k[0], k[1], k[2];
        r.d.row(i) << d[0], d[1], d[2];
      });
  return r;
}

TEST(SpringLanesProduct, IsTheStretchedSpringsDerivative) {
  // In tension the clamped geometric term is the whole one: (M + h^2 K) p - M p is h^2 times
  // minus the forces' directional derivative, support included.
  const Model& m = links_model(400);
  const Eigen::MatrixX3d x = stretched(m, 1.03);
  sim::Simulation s = linearised_at(m, x, {.anchor_stiffness_n_per_m = 0.5});
  ASSERT_TRUE(sim::detail::product_lanes_apply(s.solver()));
  const Eigen::MatrixX3d p = test::random_rows(m.node_count(), 1.0, 3);
  const double h = 0.1;
  Eigen::MatrixX3d y = Eigen::MatrixX3d::Zero(m.node_count(), 3);
  sim::implicit_system_product(s, h, p, y);
  Eigen::MatrixX3d kp = y;
  for (int32_t i = 0; i < m.node_count(); ++i)
    kp.row(i) = (y.row(i) - (s.mass_kg()[i] + h * 3.0) * p.row(i)) / (h * h);  // gamma = 3
  const double e = 1e-6;
  Eigen::MatrixX3d fp = Eigen::MatrixX3d::Zero(m.node_count(), 3), fm = fp;
  sim::internal_forces(s, x + e * p, fp);
  sim::internal_forces(s, x - e * p, fm);
  const Eigen::MatrixX3d derivative = -(fp - fm) / (2 * e);
  ASSERT_GT(derivative.cwiseAbs().maxCoeff(), 1.0);
  EXPECT_LT((kp - derivative).cwiseAbs().maxCoeff(), 1e-5 * derivative.cwiseAbs().maxCoeff());
}

TEST(SpringLanesProduct, EqualsTheNodeByNodeForceProductAndDiagonal) {
  // A shape with springs both stretched and compressed (the clamp at work): the lanes'
  // linearisation (made by the step) against spring_linearise()'s over the CSR, at the same x.
  const Model& m = links_model(400);
  const Eigen::MatrixX3d x = stretched(m, 1.02) + 0.3 * test::random_rows(m.node_count(), 1.0, 5);
  sim::Simulation s = linearised_at(m, x);
  sim::detail::Solver& solver = s.solver();
  ASSERT_TRUE(sim::detail::product_lanes_apply(solver));
  sim::detail::spring_linearise(solver, x, 1);
  const Eigen::MatrixX3d p = test::random_rows(m.node_count(), 1.0, 9);
  const Rows lanes = lane_rows(s, p, 1);
  const sim::detail::ConstCols pc(p);
  double largest_k = 0.0, largest_f = 0.0, worst_k = 0.0, worst_f = 0.0, worst_d = 0.0;
  int32_t movable = 0;
  for (int32_t i = 0; i < m.node_count(); ++i) {
    if (!solver.movable[i]) {
      EXPECT_EQ(lanes.k.row(i).squaredNorm(), 0.0) << "a held node was visited: " << i;
      continue;
    }
    ++movable;
    double k[3] = {0, 0, 0}, d[3] = {0, 0, 0}, f[3] = {0, 0, 0}, g[3] = {0, 0, 0};
    sim::detail::spring_product(solver, i, pc, k[0], k[1], k[2]);
    sim::detail::spring_diagonal(solver, i, d[0], d[1], d[2]);
    sim::detail::gather_springs(solver, i, f[0], f[1], f[2]);
    sim::detail::gather_lane_force(solver, i, g[0], g[1], g[2]);
    for (int c = 0; c < 3; ++c) {
      largest_k = std::max(largest_k, std::abs(k[c]));
      largest_f = std::max(largest_f, std::abs(f[c]));
      worst_k = std::max(worst_k, std::abs(lanes.k(i, c) - k[c]));
      worst_f = std::max(worst_f, std::abs(g[c] - f[c]));
      worst_d = std::max(worst_d, std::abs(lanes.d(i, c) - d[c]) / d[c]);
    }
  }
  EXPECT_EQ(movable, m.node_count() - static_cast<int32_t>(
                                          std::count(m.fixed.begin(), m.fixed.end(), uint8_t{1})));
  ASSERT_GT(largest_f, 0.0);
  // The force in double, summed in another order; the lanes keep w = sqrt(k (1 - alpha)) u and
  // k alpha in float (as the CSR keeps u and alpha): about 1e-7 of the terms.
  EXPECT_LT(worst_f, 1e-12 * largest_f);
  EXPECT_LT(worst_k, 1e-6 * largest_k);
  EXPECT_LT(worst_d, 1e-6);
}

TEST(SpringLanesProduct, IsTheSameOnOneAndTwoThreads) {
  // Each node's lane sums its own springs in a fixed order: the thread split changes nothing.
  const Model& m = links_model(3000);
  ASSERT_GT(m.springs.size(), 16384u);  // implicit Euler's steps take two threads from here
  sim::Simulation s = linearised_at(m, stretched(m, 1.02));
  ASSERT_TRUE(sim::detail::product_lanes_apply(s.solver()));
  const Eigen::MatrixX3d p = test::random_rows(m.node_count(), 1.0, 11);
  const Rows one = lane_rows(s, p, 1), two = lane_rows(s, p, 2);
  EXPECT_GT(one.k.cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(one.k, two.k);
  EXPECT_EQ(one.d, two.d);
}

TEST(SpringLanesProduct, ImplicitEulerSettlesWhereExplicitEulerDoes) {
  // The loaded equilibrium is the springs' balance with the load, whichever integrator (and
  // whichever of their passes, lanes or not) finds it.
  const Model& m = links_model(400);
  const int32_t front = interact::most_anterior_skin_node(m);
  const double back = m.X.col(1).maxCoeff();
  const std::vector<int32_t> held =
      sim::nodes_near_plane(m, Eigen::Vector3d(0, back, 0), Eigen::Vector3d(0, 1, 0), 15.0);
  std::vector<Eigen::MatrixX3d> settled;
  for (auto integrator : {sim::Integrator::kSemiImplicitEuler, sim::Integrator::kImplicitEuler}) {
    sim::Simulation s = sim::make_simulation(
        m, {}, {.integrator = integrator, .dt_s = 0.05, .rest_speed_mm_per_s = 0.002});
    sim::fix_nodes(s, held);
    s.f_ext.row(front) << 0.0, 20.0, 0.0;
    ASSERT_TRUE(sim::run_to_convergence(s, 1.0).converged);
    if (integrator == sim::Integrator::kImplicitEuler)
      EXPECT_TRUE(sim::detail::product_lanes_apply(s.solver()));
    settled.push_back(s.x);
  }
  const double moved = (settled[0] - m.X).rowwise().norm().maxCoeff();
  ASSERT_GT(moved, 1.0);
  EXPECT_LT((settled[1] - settled[0]).rowwise().norm().maxCoeff(), 0.01 * moved);
}

}  // namespace

namespace {

// Local mode's own blocks of lanes (LocalLanes: the paper's poke region, its nodes scattered over
// the model's blocks) step as the per-spring passes in double do, within single precision's
// forces: the same motion under a held push and after it, and both come to rest.
TEST(SpringLanes, LocalModesOwnBlocksStepAsThePerSpringPassesDo) {
  const Model& m = links_model(1284);
  const int32_t front = interact::most_anterior_skin_node(m);
  std::vector<int32_t> region;  // about the paper's four rings around the poke
  for (int32_t i = 0; i < m.node_count(); ++i)
    if ((m.X.row(i) - m.X.row(front)).norm() < 25.0) region.push_back(i);
  const auto make = [&](bool own_blocks) {
    sim::Simulation s = sim::make_simulation(m, {}, {.mode = sim::Mode::kLocal});
    sim::set_local_nodes(s, region);
    EXPECT_TRUE(s.solver().lanes.local.on) << "the region's nodes fill under half the blocks";
    if (!own_blocks) s.solver().lanes.local.on = false;  // white box: the per-spring passes
    s.f_ext.row(front) << 0.0, 400.0, 0.0;
    return s;
  };
  sim::Simulation lanes = make(true), springs = make(false);
  ASSERT_GT(region.size(), 40u);
  double peak = 0.0, apart = 0.0;
  for (int k = 0; k < 600; ++k) {
    if (k == 100) lanes.f_ext.setZero(), springs.f_ext.setZero();  // let go after 1 s
    const sim::StepStats a = sim::step(lanes), b = sim::step(springs);
    ASSERT_EQ(a.unstable, sim::Instability::kNone);
    EXPECT_NEAR(a.skin_volume_mm3, b.skin_volume_mm3, 1e-6 * b.skin_volume_mm3);
    peak = std::max(peak, (springs.x - m.X).rowwise().norm().maxCoeff());
    apart = std::max(apart, (lanes.x - springs.x).rowwise().norm().maxCoeff());
  }
  ASSERT_GT(peak, 5.0) << "the poke moves the region";
  EXPECT_LT(apart, 1e-5 * peak);                // 1.3e-7 measured
  for (int32_t i = 0; i < m.node_count(); ++i)  // nothing outside the region moved
    if (std::find(region.begin(), region.end(), i) == region.end())
      ASSERT_EQ((lanes.x.row(i) - m.X.row(i)).norm(), 0.0) << "node " << i;
}

// The lanes are made only where the springs step by themselves (not while tetrahedra carry
// them): a tissue switched from tetrahedra to the paper's springs makes them then, and steps
// (semi-implicit Euler and implicit Euler's lane products) exactly as one made with the springs.
TEST(SpringLanes, AreMadeWhenTheTissueTurnsFromTetrahedraToSprings) {
  const Model& m = test::tet_phantom();
  const sim::Material springs{.stiffness_n_per_m = 40.0, .damping_kg_per_s = 2.0};
  for (const sim::Integrator integrator :
       {sim::Integrator::kSemiImplicitEuler, sim::Integrator::kImplicitEuler}) {
    const sim::SolverOptions o{.integrator = integrator, .dt_s = 0.002};
    sim::Simulation switched = sim::make_simulation(
        m, {.stiffness_n_per_m = 0.0, .damping_kg_per_s = 2.0, .young_modulus_kpa = 6.0}, o);
    EXPECT_EQ(switched.solver().lanes.nodes, 0) << "lanes made while tetrahedra carry the springs";
    sim::set_parameters(switched, springs, o);
    sim::Simulation made = sim::make_simulation(m, springs, o);
    ASSERT_EQ(switched.solver().lanes.nodes, m.node_count());
    for (sim::Simulation* s : {&switched, &made}) {
      s->f_ext.row(interact::most_anterior_skin_node(m)) << 0.0, 300.0, 0.0;
      for (int k = 0; k < 40; ++k) ASSERT_EQ(sim::step(*s).unstable, sim::Instability::kNone);
    }
    EXPECT_GT((made.x - m.X).rowwise().norm().maxCoeff(), 0.1);
    EXPECT_EQ(switched.x, made.x) << static_cast<int>(integrator);
  }
}

}  // namespace
