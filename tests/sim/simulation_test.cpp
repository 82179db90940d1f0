#include "lamina/sim/simulation.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <Eigen/Eigenvalues>
#include <limits>
#include <random>

#include "lamina/core/error.h"
#include "lamina/geometry/make_phantom.h"
#include "lamina/geometry/mesh_measures.h"
#include "lamina/interact/tools.h"
#include "lamina/model/build_model.h"
#include "lamina/model/identify_springs.h"
#include "sim/solver.h"  // white-box: what a step visits
#include "support/random_rows.h"
#include "support/tet_phantom.h"

namespace {

using namespace lamina;

// A small two-layer phantom model (about 600 nodes), built once per process, and its support.
const Model& small_model() {
  return test::tet_phantom();
}
using test::posterior_nodes;

const char* name(sim::Integrator i) {
  return i == sim::Integrator::kImplicitEuler ? "implicit"
         : i == sim::Integrator::kProjective  ? "projective"
                                              : "semi-implicit";
}

constexpr sim::Integrator kAllIntegrators[] = {sim::Integrator::kSemiImplicitEuler,
                                               sim::Integrator::kImplicitEuler,
                                               sim::Integrator::kProjective};

double total_energy(const sim::Simulation& s) {
  double ke = 0.0;
  for (Eigen::Index i = 0; i < s.v.rows(); ++i)
    ke += 0.5 * s.mass_kg()[i] * s.v.row(i).squaredNorm();
  return ke * 1e-6 + sim::elastic_energy(s, s.x);
}

TEST(SpringForces, SumToZeroAndAreMinusTheEnergyGradient) {
  const Model& m = small_model();
  sim::Simulation s = sim::make_simulation(m);
  const Eigen::MatrixX3d x = test::jiggle(m.X, 2.0, 7);
  Eigen::MatrixX3d f = Eigen::MatrixX3d::Zero(m.node_count(), 3);
  sim::spring_forces(s, x, f);
  const double scale = f.cwiseAbs().maxCoeff();
  ASSERT_GT(scale, 0.0);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(f.col(c).sum() / scale, 0.0, 1e-12) << "axis " << c;
  // f = -dE/dx by central differences (E in J = 1e-6 N mm... : f [mN] = -dE/dx [1e-6 J / mm]).
  for (int node : {0, 17, m.node_count() - 1})
    for (int c = 0; c < 3; ++c) {
      Eigen::MatrixX3d xp = x, xm = x;
      const double h = 1e-4;
      xp(node, c) += h;
      xm(node, c) -= h;
      const double grad = (sim::spring_energy(s, xp) - sim::spring_energy(s, xm)) / (2 * h) * 1e6;
      EXPECT_NEAR(f(node, c), -grad, 1e-6 * scale + 1e-7) << "node " << node << " axis " << c;
    }
}

TEST(VolumeTerm, ForcesSumToZeroAndAreMinusTheEnergyGradient) {
  // Pressure on a closed surface has no net force, and the forces must be the energy's gradient
  // or the term would add or remove energy.
  const Model& m = small_model();
  ASSERT_GE(m.layer_count(), 2);
  sim::Simulation s =
      sim::make_simulation(m, {.stiffness_n_per_m = 0.001, .volume_stiffness_kpa = 50.0});
  const Eigen::MatrixX3d x = test::jiggle(m.X, 2.0, 11);
  Eigen::MatrixX3d f = Eigen::MatrixX3d::Zero(m.node_count(), 3);
  sim::internal_forces(s, x, f);
  Eigen::MatrixX3d springs = Eigen::MatrixX3d::Zero(m.node_count(), 3);
  sim::spring_forces(s, x, springs);
  f -= springs;  // the volume term's share
  const double scale = f.cwiseAbs().maxCoeff();
  ASSERT_GT(scale, 0.0);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(f.col(c).sum() / scale, 0.0, 1e-10) << "axis " << c;
  const double spring_part = sim::spring_energy(s, x);
  for (int node : {0, 17, m.layers[1].first_node + 3, m.node_count() - 1})
    for (int c = 0; c < 3; ++c) {
      Eigen::MatrixX3d xp = x, xm = x;
      const double h = 1e-4;
      xp(node, c) += h;
      xm(node, c) -= h;
      const double grad = ((sim::elastic_energy(s, xp) - sim::spring_energy(s, xp)) -
                           (sim::elastic_energy(s, xm) - sim::spring_energy(s, xm))) /
                          (2 * h) * 1e6;
      EXPECT_NEAR(f(node, c), -grad, 1e-5 * scale) << "node " << node << " axis " << c;
    }
  EXPECT_GT(sim::elastic_energy(s, x), spring_part);
}

TEST(VolumeTerm, KeepsTheVolumeUnderLoadAndLeavesTheRestShapeAlone) {
  // The same held poke, without and with the volume term: the term must cut the skin's volume
  // change, with every integrator, and not move a model at rest.
  const Model& m = small_model();
  const int32_t front = interact::most_anterior_skin_node(m);
  for (auto integrator : kAllIntegrators) {
    SCOPED_TRACE(name(integrator));
    std::array<double, 2> change{};
    for (int on = 0; on < 2; ++on) {
      sim::Simulation s = sim::make_simulation(
          m, {.anchor_stiffness_n_per_m = 0.3, .volume_stiffness_kpa = on ? 2.0 : 0.0},
          {.integrator = integrator, .dt_s = 0.05, .rest_speed_mm_per_s = 0.02});
      sim::fix_nodes(s, posterior_nodes(m));
      if (on) {
        const sim::StepStats rest = sim::step(s);
        EXPECT_LT(rest.max_move_mm, 1e-12);
      }
      s.f_ext.row(front) << 0.0, 60.0, 0.0;
      const sim::StepStats st = sim::run_to_convergence(s, 1.0);
      ASSERT_TRUE(st.converged);
      EXPECT_EQ(s.recoveries, 0);
      EXPECT_GT(st.max_displacement_mm, 2.0);
      change[on] = std::abs(st.volume_change_pct);
    }
    // Measured: 0.57% without, 0.051% with, for every integrator.
    EXPECT_LT(change[1], 0.5 * change[0]) << "without " << change[0] << "%, with " << change[1];
  }
}

TEST(Simulation, AtRestStaysAtRest) {
  sim::Simulation s = sim::make_simulation(small_model());
  const sim::StepStats st = sim::step(s);
  EXPECT_LT(st.max_move_mm, 1e-12);  // round-off of rest lengths only
  EXPECT_TRUE(st.converged);
  EXPECT_NEAR(st.volume_change_pct, 0.0, 1e-12);
}

TEST(Simulation, WithDampingAndNoToolEnergyNeverRises) {
  // Also with the volume term, and with mass-proportional damping alone.
  const sim::Material variants[] = {
      {}, {.volume_stiffness_kpa = 2.0}, {.damping_kg_per_s = 0.0, .mass_damping_per_s = 3.0}};
  for (auto integrator : kAllIntegrators)
    for (const sim::Material& material : variants) {
      SCOPED_TRACE(std::string(name(integrator)) + ", volume term " +
                   std::to_string(material.volume_stiffness_kpa) + " kPa, alpha " +
                   std::to_string(material.mass_damping_per_s));
      sim::Simulation s = sim::make_simulation(small_model(), material, {.integrator = integrator});
      s.x = test::jiggle(small_model().X, 1.5, 7);
      double previous = total_energy(s);
      const double start = previous;
      for (int k = 0; k < 300; ++k) {
        sim::step(s);
        const double e = total_energy(s);
        ASSERT_LE(e, previous * (1.0 + 1e-9)) << "step " << k;
        previous = e;
      }
      EXPECT_LT(previous, 0.5 * start);
    }
}

TEST(Simulation, ReleasedModelReturnsToRest) {
  for (auto integrator : kAllIntegrators)
    for (bool anchored : {false, true}) {
      SCOPED_TRACE(std::string(name(integrator)) +
                   (anchored ? ", anchor springs" : ", fixed posterior region"));
      const Model& m = small_model();
      sim::Simulation s =
          sim::make_simulation(m, {.anchor_stiffness_n_per_m = anchored ? 0.5 : 0.0},
                               {.integrator = integrator,
                                // projective dynamics costs a sparse solve per iteration: fewer,
                                // larger steps keep the test short
                                .dt_s = integrator == sim::Integrator::kProjective ? 0.05 : 0.01,
                                .rest_speed_mm_per_s = 1e-3});
      if (!anchored) sim::fix_nodes(s, posterior_nodes(m));
      const int32_t front = interact::most_anterior_skin_node(m);
      s.f_ext.row(front) << 0.0, 20.0, 0.0;  // mN, pushing the anterior surface backwards
      for (int k = 0; k < 300; ++k) sim::step(s);
      const double pushed = (s.x - m.X).rowwise().norm().maxCoeff();
      EXPECT_GT(pushed, 1.0);
      s.f_ext.setZero();
      const sim::StepStats st = sim::run_to_convergence(s);
      EXPECT_TRUE(st.converged);
      EXPECT_LT(st.max_displacement_mm, 0.01 * pushed);
    }
}

TEST(Simulation, EveryIntegratorReachesTheSameLoadedEquilibrium) {
  // The rest shape under a held load is a property of the model, not of the integrator: all
  // three settle where the springs balance the load (projective dynamics with its prefactored
  // matrix included, and after its factor is reused for hundreds of steps).
  const Model& m = small_model();
  const int32_t front = interact::most_anterior_skin_node(m);
  std::vector<Eigen::MatrixX3d> settled;
  for (auto integrator : kAllIntegrators) {
    SCOPED_TRACE(name(integrator));
    sim::Simulation s = sim::make_simulation(
        m, {}, {.integrator = integrator, .dt_s = 0.05, .rest_speed_mm_per_s = 0.002});
    sim::fix_nodes(s, posterior_nodes(m));
    s.f_ext.row(front) << 0.0, 20.0, 0.0;
    ASSERT_TRUE(sim::run_to_convergence(s, 1.0).converged);
    settled.push_back(s.x);
  }
  const double moved = (settled[0] - m.X).rowwise().norm().maxCoeff();
  ASSERT_GT(moved, 1.0);
  for (size_t k = 1; k < settled.size(); ++k)
    EXPECT_LT((settled[k] - settled[0]).rowwise().norm().maxCoeff(), 0.01 * moved)
        << name(kAllIntegrators[k]);
}

// The skin nodes within 20 mm of the most anterior one: an indenter's patch.
std::vector<int32_t> anterior_patch(const Model& m) {
  const int32_t front = interact::most_anterior_skin_node(m);
  std::vector<int32_t> patch;
  for (int32_t i = 0; i < m.layers[0].node_count; ++i)
    if ((m.X.row(i) - m.X.row(front)).norm() < 20.0) patch.push_back(i);
  return patch;
}

TEST(Simulation, HeldNodesStayWhereTheyAreHeldAndDriveTheRest) {
  // A displacement-controlled indenter: a patch of skin held 3 mm in, the back held at rest.
  const Model& m = small_model();
  const std::vector<int32_t> patch = anterior_patch(m);
  ASSERT_GT(patch.size(), 2u);
  Eigen::MatrixX3d at(static_cast<Eigen::Index>(patch.size()), 3);
  for (size_t k = 0; k < patch.size(); ++k)
    at.row(static_cast<Eigen::Index>(k)) = m.X.row(patch[k]) + Eigen::RowVector3d(0, 3, 0);
  std::vector<Eigen::MatrixX3d> settled;
  for (auto integrator : kAllIntegrators) {
    SCOPED_TRACE(name(integrator));
    sim::Simulation s = sim::make_simulation(
        m, {.anchor_stiffness_n_per_m = 0.3},
        {.integrator = integrator, .dt_s = 0.05, .rest_speed_mm_per_s = 0.002});
    sim::fix_nodes(s, posterior_nodes(m));
    sim::hold_nodes(s, patch, at);
    ASSERT_TRUE(sim::run_to_convergence(s, 1.0).converged);
    for (size_t k = 0; k < patch.size(); ++k)
      ASSERT_EQ(s.x.row(patch[k]), at.row(static_cast<Eigen::Index>(k)));
    settled.push_back(s.x);
  }
  // Neighbours follow the patch, and the three integrators agree on where.
  const double moved = (settled[0] - m.X).rowwise().norm().maxCoeff();
  EXPECT_NEAR(moved, 3.0, 1e-9);  // the patch itself; nothing overshoots it
  int followers = 0;
  for (int32_t i = 0; i < m.node_count(); ++i)
    followers += (settled[0].row(i) - m.X.row(i)).norm() > 0.3 &&
                 std::find(patch.begin(), patch.end(), i) == patch.end();
  EXPECT_GT(followers, 5);
  for (size_t k = 1; k < settled.size(); ++k)
    EXPECT_LT((settled[k] - settled[0]).rowwise().norm().maxCoeff(), 0.01 * moved);
  sim::Simulation bad = sim::make_simulation(m);
  EXPECT_THROW(sim::hold_nodes(bad, {0, 1}, Eigen::MatrixX3d::Zero(1, 3)), Error);
  EXPECT_THROW(sim::hold_nodes(bad, {-1}, Eigen::MatrixX3d::Zero(1, 3)), Error);
}

TEST(Simulation, HoldingTheSameNodesAgainMovesThemWithoutANewSetupAndTheStepMeasuresThem) {
  // An indenter or a grasper holds the same nodes at new positions every step: no new setup
  // (the prefactored solves and the step's lists stay), but the energy watch sees a tool acting
  // and the step's measurements see where the held nodes now are.
  const Model& m = small_model();
  const std::vector<int32_t> patch = anterior_patch(m);
  ASSERT_GT(patch.size(), 2u);
  sim::Simulation s = sim::make_simulation(m, {.anchor_stiffness_n_per_m = 0.3},
                                           {.integrator = sim::Integrator::kImplicitEuler});
  sim::fix_nodes(s, posterior_nodes(m));
  Eigen::MatrixX3d at(static_cast<Eigen::Index>(patch.size()), 3);
  for (size_t k = 0; k < patch.size(); ++k)
    at.row(static_cast<Eigen::Index>(k)) = m.X.row(patch[k]);
  sim::hold_nodes(s, patch, at);
  const uint64_t setup = s.solver().setup_version;
  for (int k = 1; k <= 20; ++k) {
    at.col(1).array() -= 0.5;  // 10 mm in over 20 steps
    const uint64_t moves = s.solver().held_moves;
    sim::hold_nodes(s, patch, at);
    EXPECT_EQ(s.solver().setup_version, setup) << "a new setup for the same held nodes";
    EXPECT_EQ(s.solver().held_moves, moves + 1);
    const sim::StepStats st = sim::step(s);
    ASSERT_FALSE(st.failed);
    EXPECT_EQ(st.unstable, sim::Instability::kNone);
    for (size_t q = 0; q < patch.size(); ++q)
      ASSERT_EQ(s.x.row(patch[q]), at.row(static_cast<Eigen::Index>(q)));
    // The held nodes are the farthest from rest, and the skin's volume is the one enclosed now.
    EXPECT_NEAR(st.max_displacement_mm, 0.5 * k, 1e-9);
    const double enclosed = geometry::enclosed_volume({s.x, m.layers[0].F});
    EXPECT_NEAR(st.skin_volume_mm3, enclosed, 1e-9 * enclosed);
  }
  // Holding another node is a new setup.
  int32_t other = 0;
  while (s.solver().fixed[other]) ++other;
  sim::hold_nodes(s, {other}, s.x.row(other));
  EXPECT_GT(s.solver().setup_version, setup);
}

TEST(Simulation, FixedNodesNeverMove) {
  const Model& m = small_model();
  sim::Simulation s = sim::make_simulation(m);
  const std::vector<int32_t> held = posterior_nodes(m);
  ASSERT_FALSE(held.empty());
  sim::fix_nodes(s, held);
  s.f_ext.setConstant(5.0);
  for (int k = 0; k < 50; ++k) sim::step(s);
  for (int32_t i : held) ASSERT_EQ(s.x.row(i), m.X.row(i));
}

TEST(Simulation, LocalModeMovesOnlyTheLocalNodes) {
  const Model& m = small_model();
  sim::Simulation s = sim::make_simulation(m, {}, {.mode = sim::Mode::kLocal});
  std::vector<int32_t> local;
  for (int32_t r = 0; r < m.rings.locality; ++r)
    for (int64_t k = 0; k < m.rings.ring_size(5, r); ++k) local.push_back(m.rings.ring(5, r)[k]);
  sim::set_local_nodes(s, local);
  s.f_ext.row(5) << 0.0, 0.0, -30.0;
  for (int k = 0; k < 50; ++k) sim::step(s);
  std::vector<uint8_t> is_local(static_cast<size_t>(m.node_count()), 0);
  for (int32_t i : local) is_local[i] = 1;
  int moved = 0;
  for (int32_t i = 0; i < m.node_count(); ++i) {
    const double d = (s.x.row(i) - m.X.row(i)).norm();
    if (!is_local[i]) ASSERT_EQ(d, 0.0) << "node " << i;
    moved += d > 1e-6;
  }
  EXPECT_GT(moved, 1);
}

TEST(Simulation, LocalModeStepsOnlyItsNodesAndMeasuresTheWholeModel) {
  // A local step visits the local nodes and their springs only, yet reports the same skin
  // volume and largest displacement as a measurement over the whole model would, also after
  // the local set moves on (the nodes left behind stay displaced and keep counting).
  const Model& m = small_model();
  for (auto integrator : {sim::Integrator::kSemiImplicitEuler, sim::Integrator::kImplicitEuler}) {
    sim::Simulation s =
        sim::make_simulation(m, {}, {.integrator = integrator, .mode = sim::Mode::kLocal});
    for (int32_t centre : {5, 40}) {
      std::vector<int32_t> local;
      for (int32_t r = 0; r < 3; ++r)
        for (int64_t k = 0; k < m.rings.ring_size(centre, r); ++k)
          local.push_back(m.rings.ring(centre, r)[k]);
      sim::set_local_nodes(s, local);
      ASSERT_EQ(s.solver().active_nodes.size(), local.size());
      for (int32_t e : s.solver().active_springs)
        ASSERT_TRUE(s.movable()[m.springs.i[e]] || s.movable()[m.springs.j[e]]);
      ASSERT_LT(s.solver().active_springs.size(), m.springs.size() / 4);
      s.f_ext.setZero();
      s.f_ext.row(centre) << 0.0, 0.0, -40.0;
      sim::StepStats st;
      for (int k = 0; k < 40; ++k) st = sim::step(s);
      EXPECT_NEAR(st.skin_volume_mm3, sim::layer_volume(m, s.x, 0), 1e-9 * st.skin_volume_mm3);
      EXPECT_DOUBLE_EQ(st.max_displacement_mm, (s.x - m.X).rowwise().norm().maxCoeff());
      EXPECT_GT(st.max_displacement_mm, 0.1);
    }
  }
}

TEST(Simulation, LargeDtIsSubsteppedByExplicitAndStableForImplicitIntegrators) {
  const Model& m = small_model();
  // dt = 1 s with unit masses and K = 3: semi-implicit Euler is far past its stability limit, so
  // each step runs as substeps below it: no blow-up, no rollback, and the energy decays.
  sim::Simulation ex = sim::make_simulation(m, {}, {.dt_s = 1.0});
  EXPECT_GT(sim::explicit_substeps(1.0, sim::explicit_dt_limit(ex)), 1);
  EXPECT_EQ(sim::explicit_substeps(0.01, sim::explicit_dt_limit(ex)), 1);  // the paper's dt
  ex.x = test::jiggle(m.X, 1.0, 7);
  const double ex_start = total_energy(ex);
  for (int k = 0; k < 30; ++k) sim::step(ex);
  EXPECT_EQ(ex.recoveries, 0);
  EXPECT_TRUE(ex.x.allFinite());
  EXPECT_LT(total_energy(ex), ex_start);

  for (auto integrator : {sim::Integrator::kImplicitEuler, sim::Integrator::kProjective}) {
    SCOPED_TRACE(name(integrator));
    sim::Simulation im = sim::make_simulation(m, {}, {.integrator = integrator, .dt_s = 1.0});
    im.x = test::jiggle(m.X, 1.0, 7);
    const double start = total_energy(im);
    for (int k = 0; k < 30; ++k) sim::step(im);
    EXPECT_EQ(im.recoveries, 0);
    EXPECT_LT(total_energy(im), start);
  }
}

TEST(Simulation, ANonFiniteStepIsRolledBackAndNeverSpreads) {
  // A NaN force: the step goes non-finite, is rolled back and redone (half steps, then implicit
  // Euler), and when that fails too the motion stops: no NaN reaches the state.
  sim::Simulation s = sim::make_simulation(small_model());
  s.x = test::jiggle(small_model().X, 1.0, 7);
  s.f_ext.row(3) << std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0;
  for (int k = 0; k < 5; ++k) sim::step(s);
  EXPECT_EQ(s.recoveries, 5);
  EXPECT_TRUE(s.x.allFinite());
  EXPECT_TRUE(s.v.allFinite());
}

TEST(Simulation, PhysicalLiverIsStableAtTenTimesThePapersDtWithImplicitEuler) {
  // E = 6 kPa, nu = 0.45 springs, lumped masses, the volume term and critical damping of the
  // slowest mode: semi-implicit Euler's limit is about a millisecond here, yet implicit Euler at
  // dt = 0.1 s (ten times the paper's) pushes, releases and comes back to rest with no recovery.
  Model m = small_model();
  const model::SpringIdentification id = model::identify_springs(
      m, {.young_modulus_kpa = 6.0, .poisson_ratio = 0.45}, m.springs.stiffness_n_per_m);
  sim::Material mat{.stiffness_n_per_m = 0.0,
                    .damping_kg_per_s = 0.0,
                    .node_mass_kg = 0.0,
                    .volume_stiffness_kpa = id.volume_stiffness_kpa};
  sim::Simulation s = sim::make_simulation(
      m, mat,
      {.integrator = sim::Integrator::kImplicitEuler, .dt_s = 0.1, .rest_speed_mm_per_s = 0.01});
  sim::fix_nodes(s, posterior_nodes(m));
  mat.mass_damping_per_s = 2.0 * sim::lowest_angular_frequency(s);
  sim::set_parameters(s, mat, s.options());
  const int32_t front = interact::most_anterior_skin_node(m);
  s.f_ext.row(front) << 0.0, 400.0, 0.0;  // 0.4 N, the paper's poke
  for (int k = 0; k < 10; ++k) sim::step(s);
  const double pushed = (s.x - m.X).rowwise().norm().maxCoeff();
  EXPECT_GT(pushed, 2.0);
  s.f_ext.setZero();
  const sim::StepStats st = sim::run_to_convergence(s);
  EXPECT_TRUE(st.converged);
  EXPECT_EQ(s.recoveries, 0);
  EXPECT_LT(st.max_displacement_mm, 0.01 * pushed);
}

TEST(Simulation, SameResultOnOneAndTwoThreads) {
  // Large enough (> 8192 nodes) that the step's loops really run in parallel.
  static const Model big =
      model::build_model(geometry::make_phantom({.spacing_mm = {2, 2, 2}}), {.skin_vertices = 6000})
          .model;
  ASSERT_GT(big.node_count(), 8192);
  auto run = [](int threads) {
    omp_set_num_threads(threads);
    sim::Simulation s =
        sim::make_simulation(big, {}, {.integrator = sim::Integrator::kImplicitEuler});
    s.f_ext.row(3) << 10.0, -5.0, 2.0;
    for (int k = 0; k < 5; ++k) sim::step(s);
    return s.x;
  };
  const Eigen::MatrixX3d a = run(1), b = run(2);
  omp_set_num_threads(omp_get_num_procs());
  EXPECT_GT((a - big.X).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(a, b);
}

TEST(LowestFrequency, MatchesADenseEigensolveAndItsScalingLaws) {
  const Model& m = small_model();
  sim::Simulation s = sim::make_simulation(m);
  sim::fix_nodes(s, posterior_nodes(m));
  const double omega = sim::lowest_angular_frequency(s);
  // The same by a dense eigensolve of M^-1/2 K M^-1/2 over the free nodes (unit masses here).
  std::vector<int32_t> row(static_cast<size_t>(m.node_count()), -1);
  int n = 0;
  for (int32_t i = 0; i < m.node_count(); ++i)
    if (!s.fixed()[i]) row[i] = n++;
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  for (size_t e = 0; e < m.springs.size(); ++e) {
    const int32_t a = row[m.springs.i[e]], b = row[m.springs.j[e]];
    const Eigen::Vector3d u = (m.X.row(m.springs.j[e]) - m.X.row(m.springs.i[e])).normalized();
    const Eigen::Matrix3d k = s.spring_stiffness_n_per_m()[e] * u * u.transpose();
    if (a >= 0) K.block<3, 3>(3 * a, 3 * a) += k;
    if (b >= 0) K.block<3, 3>(3 * b, 3 * b) += k;
    if (a >= 0 && b >= 0) K.block<3, 3>(3 * a, 3 * b) -= k, K.block<3, 3>(3 * b, 3 * a) -= k;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(K, Eigen::EigenvaluesOnly);
  // Within half the default tolerance (1e-4; measured 3.6e-6 off), and to 1e-6 when asked.
  const double exact = std::sqrt(eig.eigenvalues()[0]);
  EXPECT_NEAR(omega, exact, 0.5e-4 * exact);
  EXPECT_NEAR(sim::lowest_angular_frequency(s, 300, 1e-10), exact, 1e-6 * exact);
  // Four times stiffer: twice as fast; four times heavier: half as fast.
  sim::set_parameters(s, {.stiffness_n_per_m = 12.0}, s.options());
  EXPECT_NEAR(sim::lowest_angular_frequency(s), 2.0 * omega, 1e-6 * omega);
  sim::set_parameters(s, {.node_mass_kg = 4.0}, s.options());
  EXPECT_NEAR(sim::lowest_angular_frequency(s), 0.5 * omega, 1e-6 * omega);
  // Held nowhere: no slowest vibration to damp, and a clear error instead of a number.
  sim::Simulation free = sim::make_simulation(m);
  EXPECT_THROW(sim::lowest_angular_frequency(free), Error);
}

TEST(Simulation, RejectsBadParameters) {
  EXPECT_THROW(sim::make_simulation(small_model(), {}, {.dt_s = 0.0}), Error);
  EXPECT_THROW(sim::make_simulation(small_model(), {.damping_kg_per_s = -1.0}), Error);
  EXPECT_THROW(sim::make_simulation(small_model(), {.stiffness_n_per_m = std::nan("")}), Error);
  EXPECT_THROW(sim::make_simulation(small_model(), {.mass_damping_per_s = -1.0}), Error);
  EXPECT_THROW(sim::make_simulation(small_model(), {.volume_stiffness_kpa = -2.0}), Error);
}

// A refused parameter names itself and the value that arrived, so a user sees what to change.
TEST(Simulation, ARefusedParameterNamesItselfAndTheValueItGot) {
  const auto message = [](const sim::Material& m, const sim::SolverOptions& o) {
    try {
      sim::check_parameters(m, o);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(message({}, {.dt_s = -0.5}), "solver.dt: must be > 0 s, got -0.5");
  EXPECT_EQ(message({.damping_kg_per_s = -1.0}, {}), "material.damping: must be >= 0 kg/s, got -1");
  sim::Material g;
  g.gravity_mm_per_s2 = {0.0, std::nan(""), 0.0};
  EXPECT_NE(message(g, {}).find("material.gravity: must be finite, got (0, nan, 0)"),
            std::string::npos)
      << message(g, {});
  const std::string both = message({.stiffness_n_per_m = 3.0, .young_modulus_kpa = 6.0}, {});
  EXPECT_NE(both.find("got K = 3 N/m and E = 6 kPa"), std::string::npos) << both;
  EXPECT_EQ(message({}, {.max_steps = 0}), "solver.max_steps: must be >= 1, got 0");
}

// Like fix_nodes, the local nodes are checked: a bad index is an error, never silently dropped.
TEST(Simulation, BadLocalNodesAreRefusedLikeBadFixedNodes) {
  const Model m = small_model();
  sim::Simulation s = sim::make_simulation(m);
  EXPECT_THROW(sim::set_local_nodes(s, {0, m.node_count()}), Error);
  EXPECT_THROW(sim::set_local_nodes(s, {-1}), Error);
  EXPECT_THROW(sim::fix_nodes(s, {m.node_count()}), Error);
}

}  // namespace
