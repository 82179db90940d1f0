// The one-organ loop's hands (organ_loop.h): the reaction on the tip and the live forces, the
// grasper that holds, pulls and lets go, a tip's bad limits refused on the caller's thread.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "lamina/core/error.h"
#include "lamina/world/organ_loop.h"
#include "support/held_sphere.h"
#include "support/sphere_model.h"

namespace {

using namespace lamina;
using test::front_node;
using test::held_sphere;
using test::sphere_model;

const interact::RoutingOptions kNoRouting{.routing = interact::Routing::kNone};

// The one-organ loop without routing: the reaction is exactly minus the tip's load every step,
// the tip keeps pushing at rest, and a live force adds its own load, conserved.
TEST(OrganLoopHands, TheReactionIsMinusTheLoadOfTheTipAndTheForces) {
  Eigen::Vector3d c;
  const Model& m = sphere_model(&c);
  sim::Simulation s = held_sphere({});
  world::OrganLoop loop(std::move(s), kNoRouting, {.real_time = false});
  const int32_t node = front_node(m);
  loop.set_forces({{.node = node, .force_mn = Eigen::Vector3d(0, 150, 0)}});
  loop.run_steps(3000);
  world::LoopSnapshot snap;
  ASSERT_TRUE(loop.latest(snap));
  EXPECT_LT((snap.reaction_mn - Eigen::Vector3d(0, -150, 0)).norm(), 1e-9);
  EXPECT_GT(snap.x(node, 1) - m.X(node, 1), 0.5);
}

TEST(OrganLoopHands, TheGrasperHoldsPullsAndLetsGo) {
  // The viewer's, serve's and the C API's grasper: the loop closes the jaws on the skin under
  // them, the held node follows them 10 mm out, the tissue pulls them back (the reaction), and
  // once open the sphere returns to rest.
  const Model& m = test::sphere_model();
  sim::Simulation s = test::tissue_sphere();
  world::OrganLoop loop(std::move(s), {.routing = interact::Routing::kNone}, {.real_time = false});
  const int32_t node = test::front_node(m);
  const Eigen::Vector3d at = m.X.row(node).transpose();
  const Eigen::Vector3d far = at - Eigen::Vector3d(0.0, 100.0, 0.0);
  EXPECT_THROW(loop.set_grasper(interact::Jaws{.center_mm = far}), Error) << "nothing there";
  EXPECT_THROW(loop.set_grasper(interact::Jaws{.center_mm = at, .radius_mm = -1.0}), Error);
  // The far pole is fixed: jaws there are refused on the caller's thread, as the loop could not
  // hold it (it once took them and left them open on the stepping thread, with a log line).
  int32_t pole = 0;
  for (int32_t i = 0; i < m.layers[0].node_count; ++i)
    if (m.X(i, 1) > m.X(pole, 1)) pole = i;
  try {
    loop.set_grasper(interact::Jaws{.center_mm = m.X.row(pole).transpose(), .radius_mm = 2.0});
    ADD_FAILURE() << "jaws on fixed skin were taken";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("or it is fixed"), std::string::npos) << e.what();
  }

  loop.set_grasper(interact::Jaws{.center_mm = at, .radius_mm = 2.0});
  loop.run_steps(1);
  world::LoopSnapshot snap;
  ASSERT_TRUE(loop.latest(snap));
  ASSERT_FALSE(snap.grasped_nodes.empty());
  EXPECT_NE(std::find(snap.grasped_nodes.begin(), snap.grasped_nodes.end(), node),
            snap.grasped_nodes.end());
  for (int k = 1; k <= 100; ++k) {  // 10 mm out along -y over 0.1 s
    loop.set_grasper(interact::Jaws{.center_mm = at - Eigen::Vector3d(0.0, 0.1 * k, 0.0)});
    loop.run_steps(1);
  }
  loop.run_steps(50);
  loop.latest(snap);
  EXPECT_NEAR(snap.x(node, 1), at.y() - 10.0, 1e-9) << "the held node follows the jaws";
  EXPECT_GT(loop.latest_reaction().reaction_mn.y(), 10.0) << "the tissue pulls the jaws back";
  EXPECT_FALSE(snap.stats.unstable != sim::Instability::kNone);

  loop.set_grasper(std::nullopt);
  loop.run_steps(3000);
  loop.latest(snap);
  EXPECT_TRUE(snap.grasped_nodes.empty());
  EXPECT_LT((snap.x - m.X).rowwise().norm().maxCoeff(), 0.05) << "back at rest once let go";
  EXPECT_LT(loop.latest_reaction().reaction_mn.norm(), 1e-9);
}

TEST(OrganLoopHands, JawsMovedBeforeTheNextStepStillCloseWhereTheyFirstWere) {
  // A fast hand: the jaws close and move 5 mm before the loop steps once. They close where they
  // were first, so the held node is carried the whole 5 mm (closing at the last position would
  // leave it where it was).
  const Model& m = test::sphere_model();
  world::OrganLoop loop(test::tissue_sphere(), {.routing = interact::Routing::kNone},
                        {.real_time = false});
  const int32_t node = test::front_node(m);
  const Eigen::Vector3d at = m.X.row(node).transpose();
  loop.set_grasper(interact::Jaws{.center_mm = at, .radius_mm = 2.0});
  for (int k = 1; k <= 5; ++k)
    loop.set_grasper(interact::Jaws{.center_mm = at - Eigen::Vector3d(0.0, k, 0.0)});
  loop.run_steps(1);
  world::LoopSnapshot snap;
  loop.latest(snap);
  EXPECT_NEAR(snap.x(node, 1), at.y() - 5.0, 1e-9);
}

TEST(OrganLoopHands, ATipsBadLimitsAreRefusedByName) {
  world::OrganLoop loop(test::held_sphere(), kNoRouting, {.real_time = false});
  interact::ToolTip tip{.active = true, .max_force_n = -1.0};
  try {
    loop.set_tool_tip(tip);
    FAIL() << "a negative max_force_n was taken";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("max_force_n"), std::string::npos) << e.what();
  }
  tip.max_force_n = 3.0;
  tip.max_force_change_n = 0.0;
  EXPECT_THROW(loop.set_tool_tip(tip), Error);
  tip.max_force_change_n = 0.05;
  tip.radius_mm = std::nan("");
  EXPECT_THROW(loop.set_tool_tip(tip), Error);
}

}  // namespace
