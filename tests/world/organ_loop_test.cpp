// The fixed-rate simulation thread and skin picking: forces move the organ and their release
// returns it to rest, the loop never runs faster than its rate, parameters change live and are
// checked, and the reaction force balances the load at rest.
#include "lamina/world/organ_loop.h"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "lamina/core/error.h"
#include "lamina/interact/pick.h"
#include "lamina/model/build_model.h"
#include "support/held_sphere.h"
#include "support/sphere_model.h"

namespace {

using namespace lamina;

using test::front_node;
using test::held_sphere;
using test::sphere_model;

// These fixed-step tests keep the solver's own dt (the real-time loop would step 1 / rate).
const world::LoopOptions kSolverDt{.real_time = false};

TEST(OrganLoop, RefusesBadRoutingWhenMadeAndWhenSet) {
  // On the caller's thread, named: not later, in the stepping thread's first routed force.
  EXPECT_THROW(world::OrganLoop(held_sphere(), {.penetration_depth = 0}), Error);
  world::OrganLoop loop(held_sphere(), {});
  EXPECT_THROW(loop.set_parameters({}, {}, {.ring_attenuation = 2.0}), Error);
}

TEST(PickSkin, RayTowardsTheCentreHitsTheNearSideAndARayAwayMisses) {
  Eigen::Vector3d c;
  const Model& m = sphere_model(&c);
  const Eigen::Vector3d origin = c - Eigen::Vector3d(0, 100, 0);
  const interact::SkinHit hit = interact::pick_skin(m, m.X, origin, Eigen::Vector3d(0, 1, 0));
  ASSERT_GE(hit.node, 0);
  EXPECT_LT(hit.node, m.layers[0].node_count);
  EXPECT_NEAR(hit.distance_mm, 80.0, 1.5);  // the sphere's radius is 20 mm
  EXPECT_LT((m.X.row(hit.node).transpose() - hit.point).norm(), 3.0);
  EXPECT_EQ(interact::pick_skin(m, m.X, origin, Eigen::Vector3d(0, -1, 0)).node, -1);
}

TEST(OrganLoop, ForceMovesTheNodeAlongItAndReleaseReturnsToRest) {
  const Model& m = sphere_model();
  world::OrganLoop loop(held_sphere(), {}, kSolverDt);
  const int32_t node = front_node(m);
  loop.set_forces({{node, Eigen::Vector3d(0, 300, 0)}});  // 0.3 N posteriorly
  loop.run_steps(400);
  world::LoopSnapshot s;
  ASSERT_TRUE(loop.latest(s));
  const Eigen::Vector3d moved = s.x.row(node) - m.X.row(node);
  EXPECT_GT(moved.y(), 1.0);
  EXPECT_GT(moved.y(), 3.0 * std::abs(moved.x()));
  ASSERT_EQ(s.contact_nodes.size(), 1u);
  EXPECT_EQ(s.contact_nodes[0], node);

  loop.set_forces({});
  loop.run_steps(3000);
  ASSERT_TRUE(loop.latest(s));
  EXPECT_LT((s.x - m.X).rowwise().norm().maxCoeff(), 0.05 * moved.norm());
  EXPECT_TRUE(s.contact_nodes.empty());
  EXPECT_FALSE(loop.latest(s)) << "no new snapshot without steps";
}

TEST(OrganLoop, ReactionBalancesTheHeldLoadAtRest) {
  const Model& m = sphere_model();
  sim::SolverOptions implicit;  // settles in fewer steps
  implicit.integrator = sim::Integrator::kImplicitEuler;
  implicit.dt_s = 0.05;
  // P = 3: the contact and both crossings of the inner layer, none on the fixed far side (a
  // held node's load goes into its support, not back to the tool).
  interact::RoutingOptions routing;
  routing.penetration_depth = 3;
  world::OrganLoop loop(held_sphere(implicit), routing, kSolverDt);
  loop.set_forces({{front_node(m), Eigen::Vector3d(0, 200, 0)}});
  loop.run_steps(2000);
  world::LoopSnapshot s;
  ASSERT_TRUE(loop.latest(s));
  ASSERT_TRUE(s.stats.converged) << "not at rest";
  // Every routed copy pushes +y; the tissue pushes back with as much.
  const double applied = 200.0 * (1 + 0.95 + 0.95 * 0.95);
  EXPECT_NEAR(s.reaction_mn.y(), -applied, 0.02 * applied);
}

TEST(OrganLoop, ToolTipPushesTheSkinOutOfTheSphere) {
  Eigen::Vector3d c;
  const Model& m = sphere_model(&c);
  world::OrganLoop loop(held_sphere(), {}, kSolverDt);
  const int32_t node = front_node(m);
  interact::ToolTip tip;
  tip.active = true;
  tip.radius_mm = 8.0;
  // The tip comes from outside (-y): its surface reaches 5 mm past the skin.
  tip.center_mm = m.X.row(node).transpose() - Eigen::Vector3d(0, 3.0, 0);
  loop.set_tool_tip(tip);
  loop.run_steps(2000);
  world::LoopSnapshot s;
  ASSERT_TRUE(loop.latest(s));
  EXPECT_TRUE(s.tool_tip_touching);
  EXPECT_GT(s.x(node, 1) - m.X(node, 1), 1.0) << "the skin gave way under the tip";
  // Penalty contact: the deepest node is still a little inside, pushing back on the tip.
  EXPECT_LT(s.reaction_mn.y(), 0.0);
}

TEST(OrganLoop, ParametersAreCheckedAndAppliedLive) {
  world::OrganLoop loop(held_sphere(), {}, kSolverDt);
  sim::SolverOptions bad;
  bad.dt_s = -1;
  EXPECT_THROW(loop.set_parameters({}, bad, {}), Error);
  interact::RoutingOptions too_far;
  too_far.locality = 99;
  EXPECT_THROW(loop.set_parameters({}, {}, too_far), Error);
  sim::SolverOptions implicit;
  implicit.integrator = sim::Integrator::kImplicitEuler;
  implicit.dt_s = 0.05;
  loop.set_parameters({}, implicit, {});
  loop.run_steps(10);
  world::LoopSnapshot s;
  ASSERT_TRUE(loop.latest(s));
  EXPECT_NEAR(s.time_s, 0.5, 1e-9);
  EXPECT_GT(s.stats.cg_iterations, -1);
  loop.reset();
  loop.run_steps(1);
  ASSERT_TRUE(loop.latest(s));
  EXPECT_NEAR(s.time_s, 0.05, 1e-9);
}

TEST(OrganLoop, InRealTimeAStepIsOneOverTheRateWhateverTheSolversDt) {
  // The simulated clock follows the wall clock: 1 kHz steps 1 ms, whatever dt the scene or the
  // parameters ask; a new rate changes the step.
  sim::SolverOptions coarse;
  coarse.dt_s = 0.01;
  world::OrganLoop loop(held_sphere(coarse), {});  // real time at 1 kHz by default
  loop.run_steps(100);
  world::LoopSnapshot s;
  ASSERT_TRUE(loop.latest(s));
  EXPECT_NEAR(s.time_s, 0.1, 1e-9);
  EXPECT_DOUBLE_EQ(s.dt_s, 0.001);
  loop.set_parameters({}, coarse, {});
  loop.set_rate(500.0);
  loop.run_steps(100);
  ASSERT_TRUE(loop.latest(s));
  EXPECT_NEAR(s.time_s, 0.3, 1e-9);
  EXPECT_DOUBLE_EQ(s.dt_s, 0.002);
}

TEST(OrganLoop, InRealTimeNewParametersAreTakenWhileTheRateChanges) {
  // A viewer sets the rate and the parameters in one frame while the loop publishes steps at
  // the old rate: the parameters are never refused for a dt the caller does not own (the loop
  // once compared two snapshots read apart, and a step published between them threw).
  world::LoopOptions fast;
  fast.rate_hz = 3000.0;
  fast.publish_interval_s = 0.0;  // publish every step: the most chances to land between
  world::OrganLoop loop(held_sphere(), {}, fast);
  loop.start();
  sim::SolverOptions solver;
  solver.dt_s = 0.005;  // not the clock's: not looked at in real time
  // After each new rate the parameters are set back to back over the step that takes it up.
  for (int i = 0; i < 200; ++i) {
    loop.set_rate(i % 2 ? 1000.0 : 3000.0);
    const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(2);
    while (std::chrono::steady_clock::now() < until)
      ASSERT_NO_THROW(loop.set_parameters({}, solver, {})) << "rate change " << i;
  }
  loop.stop();
  world::LoopSnapshot s;
  loop.latest(s);
  EXPECT_TRUE(s.dt_s == 0.001 || s.dt_s == 1.0 / 3000.0) << s.dt_s;
}

TEST(OrganLoop, ThreadNeverOutrunsItsRateAndStopsPromptly) {
  const Model& m = sphere_model();
  world::LoopOptions o;
  o.rate_hz = 200.0;
  world::OrganLoop loop(held_sphere(), {}, o);
  loop.set_forces({{front_node(m), Eigen::Vector3d(0, 100, 0)}});
  const auto t0 = std::chrono::steady_clock::now();
  loop.start();
  std::this_thread::sleep_for(std::chrono::milliseconds(1300));
  loop.stop();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  world::LoopSnapshot s;
  loop.latest(s);
  EXPECT_GT(s.steps, 0) << "the thread did not run";
  EXPECT_LE(static_cast<double>(s.steps), 200.0 * wall + 2.0) << "faster than its rate";
  EXPECT_LE(s.achieved_rate_hz, 200.0 * 1.05);
  // Real time: never more than a simulated second per wall second; less only when the machine
  // cannot keep up (a loaded or sanitized one: its speed is the benchmarks' to measure), and
  // then the snapshot says so.
  EXPECT_GT(s.real_time_factor, 0.0) << "real time not measured";
  EXPECT_LE(s.real_time_factor, 1.05);
  EXPECT_NEAR(s.real_time_factor, s.achieved_rate_hz * s.dt_s, 1e-9);
  EXPECT_EQ(s.keeping_up, s.real_time_factor >= 0.95);
  EXPECT_FALSE(loop.running());
  EXPECT_GT(s.x(front_node(m), 1), m.X(front_node(m), 1));
}

}  // namespace
