// The world loop's hands (world_loop.h: set_tool_tip, set_grasper; what a headset's controllers
// or a haptic device drive in a world): the tip dents the body it touches and feels its push,
// lifted the body comes back; the grasper closes on the body nearest its jaws, carries its skin
// with them and feels its pull, opened the body comes back; a cut carries the grasp to the
// copies; bad hands are refused with nothing changed.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <set>
#include <thread>

#include "lamina/core/error.h"
#include "lamina/world/world_loop.h"
#include "world/run_until.h"
#include "world/two_spheres.h"

namespace lamina::world {
namespace {

using namespace test_world;

double moved_from_rest(const BodyView& b) {
  return (b.x - b.model->X).rowwise().norm().maxCoeff();
}

// A body's highest skin node at rest.
Eigen::Index highest_skin_node(const Model& m) {
  Eigen::Index top = 0;
  m.X.topRows(m.layers[0].node_count).col(2).maxCoeff(&top);
  return top;
}

TEST(WorldLoopHands, TheTipDentsTheBodyItTouchesFeelsItsPushAndLiftedTheBodyComesBack) {
  TwoSpheres t = two_spheres(0.5, 0.0, 0.0);
  WorldLoop loop(std::move(t.world), {.real_time = false});
  const Eigen::Vector3d top = sphere_centre() + Eigen::Vector3d(-8.0, 0.0, 20.0);  // on A
  interact::ToolTip tip{.active = true, .center_mm = top + Eigen::Vector3d(0, 0, 6.0)};
  loop.set_tool_tip(tip);  // above the skin: nothing touched
  loop.run_steps(20);
  WorldSnapshot snap;
  ASSERT_TRUE(loop.latest(snap));
  EXPECT_FALSE(snap.tip_touching);
  EXPECT_EQ(snap.hands_reaction_mn.norm(), 0.0);
  tip.center_mm = top + Eigen::Vector3d(0, 0, 2.0);  // 3 mm into the skin
  loop.set_tool_tip(tip);
  loop.run_steps(600);
  ASSERT_TRUE(loop.latest(snap));
  ASSERT_EQ(snap.unstable, sim::Instability::kNone);
  EXPECT_TRUE(snap.tip_touching);
  EXPECT_GT(snap.hands_reaction_mn.z(), 10.0) << "the tissue pushes the tool back up";
  // Along the sphere's outward normal under the tip (within 15 degrees).
  const Eigen::Vector3d normal = (tip.center_mm - sphere_centre()).normalized();
  EXPECT_GT(snap.hands_reaction_mn.normalized().dot(normal), std::cos(15.0 * M_PI / 180.0))
      << snap.hands_reaction_mn.transpose();
  EXPECT_GT(moved_from_rest(snap.bodies[0]), 0.5) << "A was not dented";
  EXPECT_LT(moved_from_rest(snap.bodies[1]), 0.05) << "B, untouched, moved";
  tip.active = false;
  loop.set_tool_tip(tip);
  snap = run_until_rest(loop, 3000,
                        [](const WorldSnapshot& s) { return moved_from_rest(s.bodies[0]) < 0.05; });
  EXPECT_FALSE(snap.tip_touching);
  EXPECT_EQ(snap.hands_reaction_mn.norm(), 0.0);
  EXPECT_LT(moved_from_rest(snap.bodies[0]), 0.05) << "A did not come back once the tip lifted";
}

// A haptic device reads the tip's reaction every step (latest_reaction()), not at the snapshots'
// pace: with snapshots held back, the samples still follow each step, and they are what the
// next snapshot says.
TEST(WorldLoopHands, TheReactionIsSampledEveryStepWhileSnapshotsWait) {
  TwoSpheres t = two_spheres(0.5, 0.0, 0.0);
  WorldLoop loop(std::move(t.world),
                 {.rate_hz = 0.0, .real_time = false, .threads = 1, .publish_interval_s = 3600.0});
  // The 5 mm tip 1.6 mm into A's skin.
  const Eigen::Vector3d top = sphere_centre() + Eigen::Vector3d(-8.0, 0.0, 22.0);
  loop.set_tool_tip({.active = true, .center_mm = top});
  WorldSnapshot snap;
  ASSERT_TRUE(loop.latest(snap));
  const uint64_t generation = snap.generation;
  loop.start();
  std::set<int64_t> sampled;
  interact::ReactionSample last;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (sampled.size() < 30 && std::chrono::steady_clock::now() < until) {
    last = loop.latest_reaction();
    sampled.insert(last.steps);
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  EXPECT_FALSE(loop.latest(snap)) << "a snapshot came within the hour's interval";
  loop.stop();
  EXPECT_GE(sampled.size(), 30u) << "the samples did not follow the steps";
  EXPECT_GT(last.reaction_mn.z(), 0.0) << "the tissue pushes the tip back up";
  loop.run_steps(0);  // publishes
  ASSERT_TRUE(loop.latest(snap));
  EXPECT_GT(snap.generation, generation);
  EXPECT_EQ(loop.latest_reaction().steps, snap.steps);
  EXPECT_EQ(loop.latest_reaction().reaction_mn, snap.hands_reaction_mn);
  EXPECT_EQ(loop.latest_reaction().time_s, snap.time_s);
}

TEST(WorldLoopHands, TheGrasperHoldsTheNearestBodyCarriesItWithTheJawsAndOpenedLetsItGo) {
  TwoSpheres t = two_spheres(0.5, 0.0, 0.0);
  const Eigen::Index top = highest_skin_node(*body(t.world, t.b).model);
  const Eigen::Vector3d at = body(t.world, t.b).model->X.row(top).transpose();
  WorldLoop loop(std::move(t.world), {.real_time = false});
  EXPECT_THROW(loop.set_grasper(interact::Jaws{.center_mm = at + Eigen::Vector3d(0, 0, 30)}), Error)
      << "nothing under jaws 30 mm above the skin";
  loop.set_grasper(interact::Jaws{.center_mm = at, .radius_mm = 4.0});
  loop.run_steps(5);
  WorldSnapshot snap;
  ASSERT_TRUE(loop.latest(snap));
  EXPECT_EQ(snap.grasped_body, "b");
  EXPECT_GT(snap.grasped_nodes, 0);
  // Lifted 5 mm over 0.5 s, then held.
  for (int k = 1; k <= 50; ++k) {
    loop.set_grasper(interact::Jaws{.center_mm = at + Eigen::Vector3d(0, 0, 0.1 * k)});
    loop.run_steps(10);
  }
  loop.run_steps(300);
  ASSERT_TRUE(loop.latest(snap));
  ASSERT_EQ(snap.unstable, sim::Instability::kNone);
  EXPECT_NEAR(snap.bodies[1].x(top, 2) - at.z(), 5.0, 0.2) << "the held skin follows the jaws";
  EXPECT_LT(snap.hands_reaction_mn.z(), -10.0) << "the tissue pulls the grasper back down";
  // Each body's view: what the grasper holds of it and its part of the pull.
  EXPECT_EQ(static_cast<int32_t>(snap.bodies[1].grasped_nodes.size()), snap.grasped_nodes);
  EXPECT_TRUE(snap.bodies[0].grasped_nodes.empty());
  EXPECT_EQ(snap.bodies[1].hands_reaction_mn, snap.hands_reaction_mn);
  EXPECT_EQ(snap.bodies[0].hands_reaction_mn.norm(), 0.0);
  for (const int32_t i : snap.bodies[1].grasped_nodes)
    EXPECT_EQ(snap.bodies[1].fixed[static_cast<size_t>(i)], 1) << "a held node is not held";
  for (const BodyView& v : snap.bodies) EXPECT_EQ(v.recoveries, 0);
  EXPECT_LT(moved_from_rest(snap.bodies[0]), 0.5);
  loop.set_grasper(std::nullopt);
  snap = run_until_rest(loop, 3000,
                        [](const WorldSnapshot& s) { return moved_from_rest(s.bodies[1]) < 0.05; });
  EXPECT_TRUE(snap.grasped_body.empty());
  EXPECT_EQ(snap.hands_reaction_mn.norm(), 0.0);
  EXPECT_LT(moved_from_rest(snap.bodies[1]), 0.05) << "B did not come back once let go";
  // Bad hands change nothing.
  EXPECT_THROW(loop.set_grasper(interact::Jaws{.center_mm = at, .radius_mm = -1.0}), Error);
  EXPECT_THROW(loop.set_tool_tip(interact::ToolTip{.active = true, .radius_mm = 0.0}), Error);
}

// Jaws on skin that is all fixed (B's far cap) cannot hold it: refused on the caller's thread
// (the loop once took them and left them open with a log line), and the next jaws given close
// where they are.
TEST(WorldLoopHands, JawsOnFixedSkinAreRefusedAndTheNextJawsClose) {
  TwoSpheres t = two_spheres(0.5, 0.0, 0.0);
  const Model& mb = *body(t.world, t.b).model;
  Eigen::Index far = 0;
  mb.X.topRows(mb.layers[0].node_count).col(0).maxCoeff(&far);
  const Eigen::Vector3d on_fixed = mb.X.row(far).transpose();
  ASSERT_TRUE(body(t.world, t.b).sim.fixed()[static_cast<size_t>(far)]);
  const std::vector<uint8_t> body_fixed = body(t.world, t.b).sim.fixed();
  const Eigen::Vector3d on_a =
      body(t.world, t.a).model->X.row(highest_skin_node(*body(t.world, t.a).model)).transpose();
  WorldLoop loop(std::move(t.world), {.real_time = false});
  WorldSnapshot snap;
  ASSERT_TRUE(loop.latest(snap));
  EXPECT_EQ(snap.bodies[1].fixed, body_fixed);
  try {
    loop.set_grasper(interact::Jaws{.center_mm = on_fixed, .radius_mm = 2.0});
    ADD_FAILURE() << "jaws on fixed skin were taken";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("or it is fixed"), std::string::npos) << e.what();
  }
  loop.run_steps(2);
  ASSERT_TRUE(loop.latest(snap));
  EXPECT_TRUE(snap.grasped_body.empty()) << "fixed skin was held";
  loop.set_grasper(interact::Jaws{.center_mm = on_a, .radius_mm = 4.0});
  loop.run_steps(2);
  ASSERT_TRUE(loop.latest(snap));
  EXPECT_EQ(snap.grasped_body, "a") << "the next jaws did not close";
  EXPECT_GT(snap.grasped_nodes, 0);
}

TEST(WorldLoopHands, ACutOfTheHeldBodyCarriesTheGraspToTheCopiesAndAResetOpensIt) {
  TwoSpheres t = two_spheres(0.5, 0.0, 0.0);
  const Eigen::Vector3d at =
      body(t.world, t.a).model->X.row(highest_skin_node(*body(t.world, t.a).model)).transpose();
  WorldLoop loop(std::move(t.world), {.real_time = false});
  loop.set_grasper(interact::Jaws{.center_mm = at, .radius_mm = 6.0});
  loop.run_steps(5);
  WorldSnapshot snap;
  ASSERT_TRUE(loop.latest(snap));
  ASSERT_EQ(snap.grasped_body, "a");
  const int32_t held = snap.grasped_nodes;
  const Slit s = slit_into_a();  // across A's top, under the jaws
  loop.cut(s.path, s.direction, s.depth_mm);
  loop.run_steps(5);
  ASSERT_TRUE(loop.latest(snap));
  ASSERT_EQ(snap.cuts, 1);
  EXPECT_EQ(snap.bodies[0].topology, 1u);
  EXPECT_EQ(snap.grasped_body, "a") << "the cut let go of the held body";
  EXPECT_GE(snap.grasped_nodes, held) << "the held nodes' copies are held too";
  loop.set_grasper(interact::Jaws{.center_mm = at + Eigen::Vector3d(0, 0, 3.0)});
  loop.run_steps(300);
  ASSERT_TRUE(loop.latest(snap));
  ASSERT_EQ(snap.unstable, sim::Instability::kNone);
  EXPECT_GT(moved_from_rest(snap.bodies[0]), 2.0) << "the cut body's held skin did not follow";
  loop.reset();
  loop.run_steps(1);
  ASSERT_TRUE(loop.latest(snap));
  EXPECT_TRUE(snap.grasped_body.empty()) << "a reset opens the grasper";
  EXPECT_EQ(snap.bodies[0].topology, 2u);
}

}  // namespace
}  // namespace lamina::world
