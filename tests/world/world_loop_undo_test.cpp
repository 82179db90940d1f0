// The world loop's undo and its bodies' parameters: undo_cut() takes the last cuts back one at a
// time (every body a cut divided as it was just before it, the ties it divided in place again,
// the clock running on), says so when there is none, keeps the parameters set since, and a reset
// after cuts beyond the undo depth still puts the uncut bodies back; set_parameters() changes
// one body's material and refuses what it cannot take, changing nothing.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "lamina/core/error.h"
#include "lamina/world/world_loop.h"
#include "world/two_spheres.h"

namespace lamina::world {
namespace {

using namespace test_world;

// A slit across both bodies and the tissue between them, from above, off slit_into_a()'s plane.
Slit slit_through_both() {
  const Eigen::Vector3d c = sphere_centre();
  const double y = c.y() - 2.63;  // through the ties, which lie within 5.5 mm of the axis
  return {{{c.x() - 25.0, y, c.z() + 25.0}, {c.x() + 45.0, y, c.z() + 25.0}}};
}

WorldSnapshot latest(const WorldLoop& loop) {
  WorldSnapshot s;
  EXPECT_TRUE(loop.latest(s));
  return s;
}

TEST(WorldLoopUndo, TakesTheLastCutsBackOneAtATimeWithTheirTiesAndTheClockRunsOn) {
  TwoSpheres t = two_spheres(0.5, 0.3, 0.03);  // A pressed into B for the first 30 ms
  attach(t, 30.0);
  const int32_t a_nodes = body(t.world, t.a).model->node_count();
  const int32_t b_nodes = body(t.world, t.b).model->node_count();
  WorldLoop loop(std::move(t.world), {.real_time = false});
  loop.run_steps(20);
  const WorldSnapshot before_first = latest(loop);
  const Slit s1 = slit_into_a();
  loop.cut(s1.path, s1.direction, s1.depth_mm);
  loop.run_steps(10);
  const WorldSnapshot after_first = latest(loop);
  ASSERT_EQ(after_first.cuts, 1);
  ASSERT_GT(after_first.bodies[0].model->node_count(), a_nodes);
  EXPECT_EQ(after_first.bodies[1].model->node_count(), b_nodes) << "the slit stops short of B";
  EXPECT_EQ(after_first.undoable, 1);

  const WorldSnapshot before_second = after_first;
  const Slit s2 = slit_through_both();
  loop.cut(s2.path, s2.direction, s2.depth_mm);
  loop.run_steps(0);
  const WorldSnapshot after_second = latest(loop);
  ASSERT_EQ(after_second.cuts, 3) << "the second stroke divides both bodies";
  ASSERT_GT(after_second.tie_count.divided, before_second.tie_count.divided)
      << "and the ties between them";
  EXPECT_EQ(after_second.undoable, 2);

  // The second cut back: both bodies as they were just before it (shape included), its ties in
  // place again, the clock where it was.
  loop.undo_cut();
  loop.run_steps(0);
  const WorldSnapshot undone = latest(loop);
  EXPECT_TRUE(undone.cut_message.empty()) << undone.cut_message;
  EXPECT_EQ(undone.cuts, 1);
  EXPECT_EQ(undone.tets_cut, after_first.tets_cut);
  EXPECT_EQ(undone.undoable, 1);
  EXPECT_EQ(undone.tie_count.divided, before_second.tie_count.divided);
  for (int k = 0; k < 2; ++k) {
    EXPECT_EQ(undone.bodies[k].model->node_count(), before_second.bodies[k].model->node_count());
    EXPECT_EQ(undone.bodies[k].x, before_second.bodies[k].x) << "body " << k;
    EXPECT_GT(undone.bodies[k].topology, after_second.bodies[k].topology)
        << "renumbered again: nodes picked on the cut body are refused";
  }
  EXPECT_EQ(undone.time_s, after_second.time_s) << "the clock runs on";
  EXPECT_THROW(loop.set_forces(undone.bodies[0].id, after_second.bodies[0].topology,
                               {{.node = 0, .force_mn = Eigen::Vector3d(0, 0, 10)}}),
               Error);

  // The first back too: A uncut, at its shape of then; then nothing more to undo.
  loop.run_steps(5);
  loop.undo_cut();
  loop.run_steps(0);
  const WorldSnapshot uncut = latest(loop);
  EXPECT_EQ(uncut.cuts, 0);
  EXPECT_EQ(uncut.tets_cut, 0);
  EXPECT_EQ(uncut.undoable, 0);
  EXPECT_EQ(uncut.bodies[0].model->node_count(), a_nodes);
  EXPECT_EQ(uncut.bodies[0].x, before_first.bodies[0].x);
  EXPECT_GT(uncut.time_s, undone.time_s);
  loop.undo_cut();
  loop.run_steps(0);
  const WorldSnapshot none = latest(loop);
  EXPECT_NE(none.cut_message.find("no cut to undo"), std::string::npos) << none.cut_message;
  EXPECT_EQ(none.bodies[0].model->node_count(), a_nodes);
  EXPECT_EQ(none.bodies[0].topology, uncut.bodies[0].topology) << "nothing changed";

  // The bodies step on from there, stable, the press over and the motion dying down.
  loop.run_steps(200);
  const WorldSnapshot later = latest(loop);
  EXPECT_EQ(later.unstable, sim::Instability::kNone);
  for (size_t k = 0; k < 2; ++k) {
    ASSERT_TRUE(later.bodies[k].x.allFinite());
    const auto moved = [&](const WorldSnapshot& s) {
      return (s.bodies[k].x - s.bodies[k].model->X).rowwise().norm().maxCoeff();
    };
    EXPECT_LT(moved(later), moved(none)) << later.bodies[k].name;
  }
}

// An undo joins again the ties its stroke divided, and only those: ties divided before the cut,
// or after it by another blade (a scene's dissection playing on), stay divided.
TEST(WorldLoopUndo, OnlyTheTiesItsStrokeDividedAreJoinedAgain) {
  TwoSpheres t = two_spheres(0.5, 0.0, 0.0);
  attach(t, 30.0);
  WorldLoop loop(std::move(t.world), {.real_time = false});
  const Eigen::Vector3d c = sphere_centre();
  const double x = c.x() + 20.25;                     // the plane between them, where the ties are
  const auto dissect_y = [&](double y0, double y1) {  // the ties between y0 and y1 (1.5 mm reach)
    loop.dissect({{x, y0, c.z() - 30.0}, {x, y1, c.z() - 30.0}}, Eigen::Vector3d::UnitZ(), 60.0);
    loop.run_steps(1);
    return latest(loop).tie_count.divided;
  };
  const int64_t before = dissect_y(c.y() + 3.4, c.y() + 30.0);  // the ties 1.9 mm and more up
  const Slit s = slit_through_both();  // at y = -2.63 from the centre, reaching ties within 1.5 mm
  loop.cut(s.path, s.direction, s.depth_mm);
  loop.run_steps(1);
  ASSERT_EQ(latest(loop).cuts, 2);
  const int64_t by_stroke = latest(loop).tie_count.divided - before;
  // Then those from 1 mm below: clear of the stroke's, which end 1.13 mm below.
  const int64_t after = dissect_y(c.y() + 0.5, c.y() + 30.0) - before - by_stroke;
  std::printf("ties divided: %lld before the cut, %lld by its stroke, %lld after it\n",
              static_cast<long long>(before), static_cast<long long>(by_stroke),
              static_cast<long long>(after));
  ASSERT_GT(before, 0);
  ASSERT_GT(by_stroke, 0);
  ASSERT_GT(after, 0);
  loop.undo_cut();
  loop.run_steps(1);
  const WorldSnapshot undone = latest(loop);
  EXPECT_EQ(undone.cuts, 0);
  EXPECT_EQ(undone.tie_count.divided, before + after);
  EXPECT_EQ(undone.ties_divided_by_strokes, before + after) << "the stroke's no longer counted";
}

TEST(WorldLoopUndo, CutsBeyondTheUndoDepthAreKeptForAResetWhichPutsTheBodiesBackUncut) {
  TwoSpheres t = two_spheres(0.5, 0.0, 0.0);
  attach(t, 30.0);
  const int32_t a_nodes = body(t.world, t.a).model->node_count();
  const int32_t b_nodes = body(t.world, t.b).model->node_count();
  WorldLoop loop(std::move(t.world), {.real_time = false});
  const Eigen::Vector3d c = sphere_centre();
  int divided = 0;
  for (int k = 0; k <= WorldLoop::kUndoDepth; ++k) {  // one more than can be undone
    const double y = c.y() - 12.0 + 3.0 * k + 0.37;
    loop.cut({{c.x() - 25.0, y, c.z() + 25.0}, {c.x() + 45.0, y, c.z() + 25.0}},
             -Eigen::Vector3d::UnitZ(), 50.0);
    loop.run_steps(1);
    divided = latest(loop).cuts;
  }
  WorldSnapshot s = latest(loop);
  ASSERT_GT(divided, WorldLoop::kUndoDepth);
  EXPECT_EQ(s.undoable, WorldLoop::kUndoDepth);
  loop.undo_cut();
  loop.run_steps(0);
  s = latest(loop);
  EXPECT_EQ(s.undoable, WorldLoop::kUndoDepth - 1);
  loop.reset();
  loop.run_steps(0);
  s = latest(loop);
  EXPECT_EQ(s.cuts, 0);
  EXPECT_EQ(s.undoable, 0);
  EXPECT_EQ(s.tie_count.divided, 0);
  EXPECT_EQ(s.bodies[0].model->node_count(), a_nodes);
  EXPECT_EQ(s.bodies[1].model->node_count(), b_nodes);
  for (const BodyView& b : s.bodies) EXPECT_EQ(b.x, b.model->X) << b.name << " at rest";
}

// A body's new material in a running world steps it exactly as a body made with it would, and
// leaves the other body's alone.
TEST(WorldLoopParameters, OneBodysMaterialChangesItAloneAndAnUndoKeepsIt) {
  const auto pulled = [](int how) {  // 0: as made, 1: set_parameters, 2: made stiffer
    TwoSpheres t = two_spheres(0.5, 0.0, 0.0);
    sim::Material stiffer = body(t.world, t.a).sim.material();
    stiffer.young_modulus_kpa *= 4.0;
    sim::Simulation& a = body(t.world, t.a).sim;
    if (how == 2) sim::set_parameters(a, stiffer, a.options());
    WorldLoop loop(std::move(t.world), {.real_time = false});
    const WorldSnapshot s0 = latest(loop);
    if (how == 1)
      loop.set_parameters(s0.bodies[0].id, stiffer, s0.bodies[0].solver, s0.bodies[0].routing);
    const int32_t node = skin_node_with_least_x(*s0.bodies[0].model);
    loop.set_forces(s0.bodies[0].id, s0.bodies[0].topology,
                    {{.node = node, .force_mn = Eigen::Vector3d(0, 0, 200.0)}});
    loop.run_steps(50);
    const WorldSnapshot s = latest(loop);
    EXPECT_EQ(s.unstable, sim::Instability::kNone);
    return s;
  };
  const WorldSnapshot soft = pulled(0), set = pulled(1), made = pulled(2);
  const auto moved = [](const BodyView& b) {
    return (b.x - b.model->X).rowwise().norm().maxCoeff();
  };
  std::printf("a 200 mN pull for 0.05 s moves A %.3f mm, %.3f mm with 4x its Young's modulus\n",
              moved(soft.bodies[0]), moved(set.bodies[0]));
  EXPECT_LT(moved(set.bodies[0]), 0.8 * moved(soft.bodies[0]));
  EXPECT_LT((set.bodies[0].x - made.bodies[0].x).cwiseAbs().maxCoeff(), 1e-9)
      << "as a body made with it";
  EXPECT_LT((set.bodies[1].x - made.bodies[1].x).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_EQ(set.bodies[0].material.young_modulus_kpa,
            4.0 * soft.bodies[0].material.young_modulus_kpa);
  EXPECT_EQ(set.bodies[1].material.young_modulus_kpa, soft.bodies[1].material.young_modulus_kpa)
      << "B's is its own";

  // Parameters set after a cut are kept when it is undone.
  TwoSpheres t = two_spheres(0.5, 0.0, 0.0);
  WorldLoop loop(std::move(t.world), {.real_time = false});
  const Slit s = slit_into_a();
  loop.cut(s.path, s.direction, s.depth_mm);
  loop.run_steps(1);
  WorldSnapshot cut = latest(loop);
  ASSERT_EQ(cut.cuts, 1);
  sim::Material m = cut.bodies[0].material;
  m.damping_kg_per_s *= 2.0;
  loop.set_parameters(cut.bodies[0].id, m, cut.bodies[0].solver, cut.bodies[0].routing);
  loop.run_steps(1);
  loop.undo_cut();
  loop.run_steps(1);
  const WorldSnapshot undone = latest(loop);
  EXPECT_EQ(undone.cuts, 0);
  EXPECT_EQ(undone.bodies[0].material.damping_kg_per_s, m.damping_kg_per_s);
}

TEST(WorldLoopParameters, WhatCannotBeTakenIsRefusedWithNothingChanged) {
  TwoSpheres t = two_spheres(0.5, 0.0, 0.0);
  WorldLoop loop(std::move(t.world), {.real_time = false});
  const WorldSnapshot s0 = latest(loop);
  const BodyView& a = s0.bodies[0];
  const auto refused = [&](const auto& call, const char* what) {
    try {
      call();
      ADD_FAILURE() << "accepted: " << what;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::kInvalidInput) << what;
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << "one line: " << e.what();
    }
  };
  sim::Material bad = a.material;
  bad.damping_kg_per_s = -1.0;
  refused([&] { loop.set_parameters(a.id, bad, a.solver, a.routing); }, "negative damping");
  {  // in real time dt is 1 / rate: another is refused
    WorldLoop real_time(std::move(two_spheres(0.5, 0.0, 0.0).world), {.rate_hz = 500.0});
    const WorldSnapshot r = latest(real_time);
    sim::SolverOptions other_dt = r.bodies[0].solver;
    other_dt.dt_s *= 2.0;
    refused([&] { real_time.set_parameters(r.bodies[0].id, a.material, other_dt, a.routing); },
            "another dt in real time");
  }
  interact::RoutingOptions far = a.routing;
  far.routing = interact::Routing::kPaper;
  far.locality = a.model->rings.locality + 5;
  refused([&] { loop.set_parameters(a.id, a.material, a.solver, far); }, "rings not made");
  refused(
      [&] {
        loop.set_parameters({a.id.index, a.id.generation + 1}, a.material, a.solver, a.routing);
      },
      "a stale handle");
  loop.run_steps(1);
  const WorldSnapshot s1 = latest(loop);
  EXPECT_EQ(s1.bodies[0].material.damping_kg_per_s, a.material.damping_kg_per_s);
  EXPECT_EQ(s1.bodies[0].solver.dt_s, a.solver.dt_s);
  EXPECT_EQ(s1.bodies[0].routing.locality, a.routing.locality);
}

// Without real time dt is the world's: a new one set on one body is every body's (the one-organ
// loop's caller sets dt this way: a world of one body).
TEST(WorldLoopParameters, WithoutRealTimeANewDtIsEveryBodysUnlessLeftToTheWorld) {
  TwoSpheres t = two_spheres(0.5, 0.0, 0.0);
  WorldLoop loop(std::move(t.world), {.real_time = false});
  const WorldSnapshot s0 = latest(loop);
  ASSERT_EQ(s0.bodies.size(), 2u);
  const BodyView& a = s0.bodies[0];
  sim::SolverOptions half = a.solver;
  half.dt_s *= 0.5;
  loop.set_parameters(a.id, a.material, half, a.routing);
  loop.run_steps(2);
  const WorldSnapshot s1 = latest(loop);
  EXPECT_EQ(s1.dt_s, half.dt_s);
  for (const BodyView& b : s1.bodies) EXPECT_EQ(b.solver.dt_s, half.dt_s) << b.name;
  EXPECT_NEAR(s1.time_s - s0.time_s, 2 * half.dt_s, 1e-12);
  // A panel that changed a damping and left dt to the world (Dt::kTheWorlds): its older dt is
  // not taken, the damping is; in real time it is not refused either.
  sim::Material damped = a.material;
  damped.damping_kg_per_s *= 2.0;
  loop.set_parameters(a.id, damped, a.solver, a.routing, WorldLoop::Dt::kTheWorlds);
  loop.run_steps(1);
  const WorldSnapshot s2 = latest(loop);
  EXPECT_EQ(s2.dt_s, half.dt_s);
  EXPECT_EQ(s2.bodies[0].material.damping_kg_per_s, damped.damping_kg_per_s);
  WorldLoop real_time(std::move(two_spheres(0.5, 0.0, 0.0).world), {.rate_hz = 500.0});
  const WorldSnapshot r = latest(real_time);
  EXPECT_NO_THROW(
      real_time.set_parameters(r.bodies[0].id, damped, half, a.routing, WorldLoop::Dt::kTheWorlds));
  real_time.run_steps(1);
  EXPECT_EQ(latest(real_time).dt_s, 1.0 / 500.0);
}

}  // namespace
}  // namespace lamina::world
