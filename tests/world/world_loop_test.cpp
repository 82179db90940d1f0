// The world's real-time loop: it steps the world exactly as world::step() does, a live force on
// one body reaches the other through contact and the pair comes back to rest when released, a
// stroke divides the ties it passes and a reset puts them back, stale handles and bad commands
// are refused with nothing changed, and the thread follows the wall clock's step.
#include "lamina/world/world_loop.h"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "lamina/core/error.h"
#include "world/run_until.h"
#include "world/two_spheres.h"

namespace lamina::world {
namespace {

using namespace test_world;

// A pair with ties and a scene's blade sweeping across their meeting in the first 50 ms (A,
// pressed, moves part of it off the blade's plane: some ties divided, not all).
struct Scene {
  TwoSpheres t;
  std::vector<Dissection> blades;
};

Scene tied_pair(double press_n) {
  Scene s{two_spheres(0.5, press_n, 0.3), {}};
  attach(s.t, 30.0);
  const Eigen::Vector3d c = sphere_centre();
  const double x = c.x() + 20.25;  // the plane between them
  Dissection d;
  d.blade.path = {{x, c.y() - 30.0, c.z() - 30.0}, {x, c.y() + 30.0, c.z() - 30.0}};
  d.blade.depth_direction = Eigen::Vector3d::UnitZ();
  d.blade.depth_mm = 60.0;
  d.blade.start_s = 0.0;  // before the press has moved the bodies' meeting off the plane
  d.blade.end_s = 0.05;
  d.reach_mm = 1.5;
  s.blades.push_back(d);
  return s;
}

double moved_from_rest(const BodyView& b) {
  return (b.x - b.model->X).rowwise().norm().maxCoeff();
}

TEST(WorldLoop, StepsTheWorldExactlyAsWorldStepAndItsBladesDo) {
  Scene ref = tied_pair(1.0);
  Scene run = tied_pair(1.0);
  WorldStepStats st;
  for (int k = 0; k < 300; ++k) {
    const double t = ref.t.world.time_s;
    advance_dissections(ref.blades, ref.t.world, t, t + 1e-3);
    step(ref.t.world, st);
  }
  // Not in real time: the bodies' own dt (1 ms), whatever the rate.
  WorldLoop loop(std::move(run.t.world), {.real_time = false, .dissections = run.blades});
  loop.run_steps(300);
  WorldSnapshot snap;
  ASSERT_TRUE(loop.latest(snap));
  ASSERT_EQ(snap.bodies.size(), 2u);
  EXPECT_EQ(snap.steps, 300);
  EXPECT_GT(snap.tie_count.divided, 0);
  EXPECT_LT(snap.tie_count.divided, snap.tie_count.total);
  EXPECT_EQ(snap.tie_count.divided, count_ties(ref.t.world).divided);
  EXPECT_EQ(static_cast<int64_t>(snap.ties.size()),
            snap.tie_count.total - snap.tie_count.divided - snap.tie_count.torn);
  EXPECT_EQ(snap.bodies[0].name, "a");
  EXPECT_EQ(snap.bodies[0].x, body(ref.t.world, ref.t.a).sim.x);
  EXPECT_EQ(snap.bodies[1].x, body(ref.t.world, ref.t.b).sim.x);
}

TEST(WorldLoop, ALiveForceOnOneBodyPushesTheOtherAndReleasedBothComeBackToRest) {
  TwoSpheres t = two_spheres(0.5, 0.0, 0.0);
  const int32_t node = skin_node_with_least_x(*body(t.world, t.a).model);
  WorldLoop loop(std::move(t.world), {.real_time = false});
  const auto handles = loop.bodies();
  ASSERT_EQ(handles.size(), 2u);
  // 1 N towards B on A's far side, spread over its half.
  loop.set_forces(handles[0].first, handles[0].second,
                  {{.node = node, .force_mn = {1000.0, 0.0, 0.0}, .radius_mm = 25.0}});
  loop.run_steps(800);
  WorldSnapshot snap;
  ASSERT_TRUE(loop.latest(snap));
  ASSERT_EQ(snap.unstable, sim::Instability::kNone);
  EXPECT_EQ(snap.bodies[0].force_nodes, std::vector<int32_t>{node});
  EXPECT_GT(snap.bodies[1].stats.contacts + snap.bodies[0].stats.contacts, 0);
  EXPECT_GT(snap.bodies[1].stats.contact_force_mn.x(), 200.0) << "B took none of the push";
  EXPECT_GT(moved_from_rest(snap.bodies[1]), 0.1) << "B did not move under A's push";
  EXPECT_LE(
      std::max(snap.bodies[0].stats.max_penetration_mm, snap.bodies[1].stats.max_penetration_mm),
      0.5);
  loop.clear_forces();
  snap = run_until_rest(loop, 3000, [](const WorldSnapshot& s) {
    return moved_from_rest(s.bodies[1]) < 0.05 && moved_from_rest(s.bodies[0]) < 0.25;
  });
  EXPECT_TRUE(snap.bodies[0].force_nodes.empty());
  EXPECT_LT(moved_from_rest(snap.bodies[1]), 0.05);
  EXPECT_LT(moved_from_rest(snap.bodies[0]), 0.25);
}

TEST(WorldLoop, AStrokeDividesTheTiesItPassesAndAResetPutsThemBack) {
  Scene s = tied_pair(0.0);
  const Eigen::Vector3d c = sphere_centre();
  const double x = c.x() + 20.25;
  WorldLoop loop(std::move(s.t.world), {.real_time = false});
  loop.dissect({{x, c.y() - 30.0, c.z() - 30.0}, {x, c.y() + 30.0, c.z() - 30.0}},
               Eigen::Vector3d::UnitZ(), 60.0);
  loop.run_steps(1);
  WorldSnapshot snap;
  ASSERT_TRUE(loop.latest(snap));
  EXPECT_GT(snap.tie_count.total, 10);
  EXPECT_EQ(snap.tie_count.divided, snap.tie_count.total);
  EXPECT_EQ(snap.ties_divided_by_strokes, snap.tie_count.total);
  EXPECT_TRUE(snap.ties.empty());
  loop.reset();
  loop.run_steps(0);
  ASSERT_TRUE(loop.latest(snap));
  EXPECT_EQ(snap.tie_count.divided, 0);
  EXPECT_EQ(snap.ties_divided_by_strokes, 0);
  EXPECT_EQ(snap.time_s, 0.0);
}

TEST(WorldLoop, StaleHandlesOlderTopologiesAndBadCommandsAreRefusedChangingNothing) {
  Scene ref = tied_pair(1.0);
  Scene run = tied_pair(1.0);
  WorldLoop reference(std::move(ref.t.world), {.real_time = false});
  WorldLoop loop(std::move(run.t.world), {.real_time = false});
  const auto [id, topology] = loop.bodies()[0];
  const interact::LiveForce push{.node = 0, .force_mn = {100.0, 0.0, 0.0}};
  const auto refused = [](const auto& call, const char* what) {
    try {
      call();
      ADD_FAILURE() << "accepted: " << what;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::kInvalidInput) << what;
    }
  };
  refused(
      [&] {
        loop.set_forces({id.index, id.generation + 1}, topology, {push});
      },
      "a stale generation");
  refused([&] { loop.set_forces({7, 1}, topology, {push}); }, "a slot with no body");
  refused([&] { loop.set_forces(id, topology + 1, {push}); }, "another topology");
  refused([&] { loop.set_forces(id, topology, {{.node = 1 << 20}}); }, "a node off the skin");
  refused([&] { loop.set_forces(id, topology, {{.node = -1}}); }, "node -1");
  refused(
      [&] {
        loop.set_forces(id, topology, {{.node = 0, .force_mn = {NAN, 0.0, 0.0}}});
      },
      "a force that is not finite");
  const Eigen::Vector3d p(0.0, 0.0, 0.0), q(0.0, 10.0, 0.0), z = Eigen::Vector3d::UnitZ();
  refused([&] { loop.dissect({p}, z, 10.0); }, "a one-point stroke");
  refused([&] { loop.dissect({p, q}, Eigen::Vector3d::Zero(), 10.0); }, "no direction");
  refused([&] { loop.dissect({p, q}, z, 0.0); }, "no depth");
  refused([&] { loop.dissect({p, Eigen::Vector3d(NAN, 0.0, 0.0)}, z, 10.0); }, "a NaN point");
  reference.run_steps(50);
  loop.run_steps(50);
  WorldSnapshot a, b;
  reference.latest(a);
  loop.latest(b);
  EXPECT_EQ(a.bodies[0].x, b.bodies[0].x);
  EXPECT_EQ(a.bodies[1].x, b.bodies[1].x);
  EXPECT_EQ(b.tie_count.divided, 0);
  EXPECT_THROW(WorldLoop(World{}), Error) << "a world with no body";
}

TEST(WorldLoop, InRealTimeEveryBodyStepsOneOverTheRateAndTheClockFollowsTheSteps) {
  TwoSpheres t = two_spheres(0.5, 0.0, 0.0);
  WorldLoop loop(std::move(t.world), {.rate_hz = 500.0, .threads = 1});
  loop.start();
  WorldSnapshot snap;
  // Up to 20 s for 50 steps: what this checks is the step's dt and the clock, not the speed
  // (under ASan on a slow 2-core machine a step of the two spheres took 60-130 ms).
  for (int k = 0; k < 4000 && snap.steps < 50; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    loop.latest(snap);
  }
  loop.set_paused(true);
  loop.stop();
  loop.latest(snap);
  ASSERT_GE(snap.steps, 50) << "the loop did not step";
  EXPECT_EQ(snap.dt_s, 1.0 / 500.0);
  EXPECT_NEAR(snap.time_s, static_cast<double>(snap.steps) * snap.dt_s, 1e-9);
  EXPECT_EQ(snap.unstable, sim::Instability::kNone);
}

// The stepping thread counts its waits for a caller's lock. A caller copying a fresh snapshot
// back to back holds the snapshot lock most of the time, so most publishes must wait (counted
// by LockWaits, tests/core), each about one copy long, never anything like a second. (A one-organ
// loop's caller cannot do this: OrganLoop copies a world snapshot only when it is new.)
TEST(WorldLoop, CountsTheStepsThatWaitedForACallersCopy) {
  TwoSpheres t = two_spheres(0.5, 0.0, 0.0);
  WorldLoop loop(std::move(t.world),
                 {.rate_hz = 0.0, .real_time = false, .threads = 1, .publish_interval_s = 0.0});
  loop.start();
  const auto t0 = std::chrono::steady_clock::now();
  int64_t copies = 0;
  int64_t steps = 0;
  // 20 publishes at least (under ASan a step of the pair took up to 130 ms), 20 s at most.
  while (steps < 20 && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(20)) {
    WorldSnapshot s;  // empty: every call copies under the lock
    copies += loop.latest(s);
    steps = s.steps;
  }
  loop.stop();
  WorldSnapshot s;
  loop.latest(s);
  ASSERT_GE(s.steps, 20) << "the loop did not step";
  EXPECT_GT(copies, 0);
  EXPECT_GT(s.lock_waits, 0) << copies << " copies beside " << s.steps << " steps";
  EXPECT_LE(s.lock_waits, 3 * s.steps + 3) << "at most one wait per lock a step takes";
  EXPECT_GT(s.longest_lock_wait_us, 0.0);
  EXPECT_LT(s.longest_lock_wait_us, 1e6);
}

}  // namespace
}  // namespace lamina::world
