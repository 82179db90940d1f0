// The watch for instability (issue 31: never silently wrong): a released organ is never called
// unstable, whatever the integrator or gravity; what leaves physical bounds is, each for its
// own reason (steps failing in a row, energy pumped in with no tool, a solver that stalls); and
// reset() starts afresh.
#include <gtest/gtest.h>

#include "lamina/interact/tools.h"
#include "lamina/sim/simulation.h"
#include "sim/force_terms.h"  // white box: the springs' energy in parts
#include "sim/solver.h"
#include "support/tet_phantom.h"

namespace {

using namespace lamina;

// The small phantom (tests/support/tet_phantom.h) held at its back.
sim::Simulation held(const sim::Material& mat, const sim::SolverOptions& o) {
  sim::Simulation s = sim::make_simulation(test::tet_phantom(), mat, o);
  sim::fix_nodes(s, test::posterior_nodes(test::tet_phantom()));
  return s;
}

// Steps with `f` on the most anterior skin node for `push` steps, then lets go and steps
// until at rest; fails the test at the first step called unstable.
void poke_and_release(sim::Simulation& s, double f_mn, int push) {
  const int32_t front = interact::most_anterior_skin_node(s.model());
  s.f_ext.row(front) << 0.0, f_mn, 0.0;
  for (int k = 0; k < push; ++k)
    ASSERT_EQ(sim::step(s).unstable, sim::Instability::kNone) << "loaded, step " << k;
  s.f_ext.setZero();
  sim::RestStreak rest{.needed = sim::quiet_steps(s)};
  for (int64_t k = 0; k < 20000; ++k) {
    const sim::StepStats st = sim::step(s);
    ASSERT_EQ(st.unstable, sim::Instability::kNone) << "released, step " << k;
    if (rest.update(st)) return;
  }
  FAIL() << "never came to rest";
}

// A physical liver: E = 6 kPa through the tetrahedra, lumped masses, mass-proportional damping.
sim::Material physical(const Eigen::Vector3d& gravity = Eigen::Vector3d::Zero()) {
  return {.stiffness_n_per_m = 0.0,
          .damping_kg_per_s = 0.0,
          .mass_damping_per_s = 5.0,
          .node_mass_kg = 0.0,
          .young_modulus_kpa = 6.0,
          .gravity_mm_per_s2 = gravity};
}

TEST(StabilityWatch, APokedOrganLetGoIsNeverCalledUnstable) {
  // Released stored energy turns into motion (kinetic energy rises), and gravity pulls: neither
  // is a blow-up. The paper's springs with semi-implicit Euler and with projective dynamics
  // (without gravity: its 1 kg nodes on 3 N/m springs would sag metres, rightly refused), and a
  // physical liver with implicit Euler, with and without gravity.
  {
    SCOPED_TRACE("semi-implicit");
    sim::Simulation s = held({}, {});
    poke_and_release(s, 20.0, 300);
  }
  {
    SCOPED_TRACE("projective");
    sim::Simulation s = held({}, {.integrator = sim::Integrator::kProjective, .dt_s = 0.05});
    poke_and_release(s, 20.0, 60);
  }
  for (bool with_gravity : {false, true}) {
    SCOPED_TRACE(with_gravity ? "implicit, gravity" : "implicit");
    const Eigen::Vector3d g = with_gravity ? Eigen::Vector3d(0, 9810, 0) : Eigen::Vector3d::Zero();
    sim::Simulation s = held(physical(g), {.integrator = sim::Integrator::kImplicitEuler});
    poke_and_release(s, 400.0, 50);
  }
}

TEST(StabilityWatch, EnergyPumpedInWithoutAToolIsCalledUnstableAndResetStartsAfresh) {
  // Velocities written straight into the state grow by 5% a step: no f_ext, nothing held or
  // moved through the API, so no tool acts, and the total energy climbs past twice its start.
  sim::Simulation s = held({}, {});
  const int32_t front = interact::most_anterior_skin_node(s.model());
  s.v.row(front) << 0.0, 50.0, 0.0;
  int64_t at = -1;
  for (int64_t k = 0; k < 400 && at < 0; ++k) {
    for (int32_t i = 0; i < s.model().node_count(); ++i)
      if (s.movable()[i]) s.v.row(i) *= 1.05;
    const sim::StepStats st = sim::step(s);
    if (st.unstable != sim::Instability::kNone) {
      EXPECT_EQ(st.unstable, sim::Instability::kEnergyGrowth);
      at = k;
    }
  }
  ASSERT_GE(at, sim::kEnergyCheckSteps) << "called unstable before its first energy check";
  // Latched: the next step says so again, whatever it measures.
  EXPECT_EQ(sim::step(s).unstable, sim::Instability::kEnergyGrowth);
  sim::reset(s);
  EXPECT_EQ(sim::step(s).unstable, sim::Instability::kNone);
}

// The watch sums the springs that move each time and takes the others' energy from a cache made
// when the nodes that do not move change (local mode's frozen part, held nodes): the two parts
// are the whole energy, however far the held nodes were moved before they were held, and stay so
// as the rest moves on.
TEST(StabilityWatch, TheSpringsThatStayPutAreCountedFromTheirCache) {
  sim::Simulation s = held({}, {});
  const Model& m = s.model();
  const int32_t front = interact::most_anterior_skin_node(m);
  s.f_ext.row(front) << 0.0, 20.0, 0.0;
  for (int k = 0; k < 100; ++k) sim::step(s);
  // The poked part of the organ, held where the poke has moved it.
  std::vector<int32_t> upper;
  const double reach = 0.3 * (m.X.colwise().maxCoeff() - m.X.colwise().minCoeff()).maxCoeff();
  for (int32_t i = 0; i < m.node_count(); ++i)
    if ((m.X.row(i) - m.X.row(front)).norm() < reach && s.movable()[i]) upper.push_back(i);
  ASSERT_GT(upper.size(), 10u);
  Eigen::MatrixX3d where(static_cast<Eigen::Index>(upper.size()), 3);
  for (size_t k = 0; k < upper.size(); ++k)
    where.row(static_cast<Eigen::Index>(k)) = s.x.row(upper[k]);
  sim::hold_nodes(s, upper, where);
  s.f_ext.setZero();
  const sim::detail::Solver& solver = s.solver();
  using Springs = sim::detail::EdgeSprings;
  for (int round = 0; round < 2; ++round) {
    if (round == 1) {  // the clamp stretches what it holds: the cache must be made again
      const double y = s.x(front, 1);
      where.col(1) = (where.col(1).array() - y) * 1.05 + y;
      sim::hold_nodes(s, upper, where);
    }
    // Quiet steps: the watch takes the energy (and makes the cache) every kEnergyCheckSteps.
    for (int64_t k = 0; k < 2 * sim::kEnergyCheckSteps; ++k)
      ASSERT_EQ(sim::step(s).unstable, sim::Instability::kNone);
    ASSERT_FALSE(solver.frozen_spring_energy_stale);
    const double whole = Springs::energy_mj(solver, s.x);
    ASSERT_GT(solver.frozen_spring_energy_mj, 0.05 * whole) << "the held part stores energy";
    EXPECT_NEAR(Springs::part_energy_mj(solver, s.x, true) + solver.frozen_spring_energy_mj, whole,
                1e-9 * whole)
        << "round " << round;
  }
}

TEST(StabilityWatch, ALoadBeyondTheOrgansSizeFailsTenStepsThenIsUnstable) {
  // 1e9 N on one node: backward Euler, the last resort of the redo, moves it farther than the
  // organ is wide, so each step is refused (the state kept, finite), and ten in a row are
  // unstable.
  sim::Simulation s = held({}, {.integrator = sim::Integrator::kImplicitEuler});
  const int32_t front = interact::most_anterior_skin_node(s.model());
  s.f_ext.row(front) << 0.0, 1e12, 0.0;
  for (int64_t k = 1; k <= sim::kFailedStepsToUnstable; ++k) {
    const sim::StepStats st = sim::step(s);
    EXPECT_TRUE(st.failed) << k;
    EXPECT_EQ(st.unstable, k < sim::kFailedStepsToUnstable ? sim::Instability::kNone
                                                           : sim::Instability::kStepsFailed)
        << k;
  }
  EXPECT_TRUE(s.x.allFinite());
  EXPECT_LT((s.x - s.model().X).rowwise().norm().maxCoeff(),
            (s.model().X.colwise().maxCoeff() - s.model().X.colwise().minCoeff()).norm());
}

TEST(StabilityWatch, AForceThatMovesTheOrganFarButWithinItsSizeIsNotAFailure) {
  // The bound is twice the organ's own size, not a small fraction of it: a paper-model poke that
  // dents the skin by centimetres is a deformation, and no step is refused.
  sim::Simulation s = held({}, {});
  const int32_t front = interact::most_anterior_skin_node(s.model());
  s.f_ext.row(front) << 0.0, 150.0, 0.0;  // 0.15 N on K = 3 N/m springs: tens of mm
  double peak = 0.0;
  for (int k = 0; k < 600; ++k) {
    const sim::StepStats st = sim::step(s);
    ASSERT_FALSE(st.failed) << k;
    peak = std::max(peak, st.max_displacement_mm);
  }
  EXPECT_GT(peak, 10.0);
  EXPECT_EQ(s.recoveries, 0);
}

TEST(StabilityWatch, ASolverThatMissesItsToleranceStepAfterStepIsUnstable) {
  // One conjugate-gradient iteration a step against a 1e-12 tolerance under a steady push on a
  // physical liver (whose light nodes make the system far from its diagonal):
  // every solve stops short; kUnsolvedStepsToUnstable of them in a row are unstable, and the
  // residual each step reports is the one that missed.
  sim::Simulation s = held(physical(), {.integrator = sim::Integrator::kImplicitEuler,
                                        .cg_max_iterations = 1,
                                        .cg_tolerance = 1e-12});
  const int32_t front = interact::most_anterior_skin_node(s.model());
  s.f_ext.row(front) << 0.0, 400.0, 0.0;
  sim::StepStats st;
  for (int64_t k = 1; k <= sim::kUnsolvedStepsToUnstable; ++k) {
    st = sim::step(s);
    ASSERT_FALSE(st.solver_converged) << k;
    EXPECT_GT(st.solver_residual, 1e-12) << k;
    ASSERT_EQ(st.unstable, k < sim::kUnsolvedStepsToUnstable ? sim::Instability::kNone
                                                             : sim::Instability::kSolverStalled)
        << k;
  }
  // The same push solved to tolerance is no stall.
  sim::Simulation good = held(physical(), {.integrator = sim::Integrator::kImplicitEuler});
  good.f_ext.row(front) << 0.0, 400.0, 0.0;
  for (int64_t k = 0; k < 2 * sim::kUnsolvedStepsToUnstable; ++k) {
    st = sim::step(good);
    ASSERT_TRUE(st.solver_converged) << k;
    ASSERT_EQ(st.unstable, sim::Instability::kNone);
  }
}

}  // namespace
