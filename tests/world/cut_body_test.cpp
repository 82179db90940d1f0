// A scalpel through a body of a world (world::cut_body, the one place where a body's topology
// changes): the ties on its nodes and skin follow the copies to the same points, the body steps
// on in contact with its neighbour and comes back to rest, a blade that misses changes nothing,
// and bad calls are refused with the world unchanged. The world loop's cut: the body's old node
// numbers refused, its live forces carried to the copies (a drag goes on through the cut), and
// a reset puts the uncut body back.
#include "lamina/world/cut_body.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <thread>

#include "lamina/core/error.h"
#include "lamina/world/world_loop.h"
#include "world/two_spheres.h"

namespace lamina::world {
namespace {

using namespace test_world;

std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> every_tie_end(const World& w) {
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> out;
  for (const AttachmentSlot& a : w.attachments)
    for (const Tie& t : a.attachment.ties) out.push_back(tie_ends(w, t));
  return out;
}

TEST(CutBody, TheTiesFollowTheCopiesAndTheCutBodyStepsOnInContactAndComesBackToRest) {
  TwoSpheres t = two_spheres(0.5, 1.0, 0.3);
  const AttachmentId at = attach(t, 30.0);
  const std::vector<Tie> ties_before = attachment(t.world, at).ties;
  const auto ends_before = every_tie_end(t.world);
  const int32_t nodes_before = body(t.world, t.a).model->node_count();
  const int32_t b_nodes = body(t.world, t.b).model->node_count();

  const Slit s = slit_into_a();
  std::vector<int32_t> origin;
  const model::CutReport r = cut_body(t.world, t.a, s.path, s.direction, s.depth_mm, &origin);
  ASSERT_GT(r.cut_tets, 0);
  const Body& a = body(t.world, t.a);
  EXPECT_EQ(a.topology, 1u);
  EXPECT_EQ(body(t.world, t.b).topology, 0u);
  EXPECT_EQ(body(t.world, t.b).model->node_count(), b_nodes);
  ASSERT_GT(a.model->node_count(), nodes_before);
  ASSERT_EQ(origin.size(), static_cast<size_t>(a.model->node_count()));
  EXPECT_EQ(a.rest_overlap_mm.size(), origin.size());
  EXPECT_EQ(&a.sim.model(), a.model.get());

  // Every tie on A's side holds a copy of its old node, every point on A's skin lies on copies
  // of its old corners: the same tissue, the same points.
  const std::vector<Tie>& ties = attachment(t.world, at).ties;
  ASSERT_EQ(ties.size(), ties_before.size());
  for (size_t k = 0; k < ties.size(); ++k) {
    if (ties[k].node_body == t.a.index) {
      EXPECT_EQ(origin[static_cast<size_t>(ties[k].node)], ties_before[k].node);
      EXPECT_LT(ties[k].node, a.model->layers[0].node_count) << "a tie left the skin";
    }
    if (ties[k].surface_body == t.a.index)
      for (int c = 0; c < 3; ++c)
        EXPECT_EQ(origin[static_cast<size_t>(ties[k].corners[c])], ties_before[k].corners[c]);
  }
  const auto ends = every_tie_end(t.world);
  for (size_t k = 0; k < ends.size(); ++k) {
    EXPECT_LT((ends[k].first - ends_before[k].first).norm(), 1e-9);
    EXPECT_LT((ends[k].second - ends_before[k].second).norm(), 1e-9);
  }

  // A, cut, pressed into B for 0.3 s (its press followed the copies), then up to 2 s free until
  // both are at rest.
  WorldStepStats st;
  double b_force = 0.0, penetration = 0.0;
  for (int k = 0; k < 2300; ++k) {
    step(t.world, st);
    ASSERT_EQ(st.unstable, sim::Instability::kNone) << "step " << k << ": " << st.unstable_body;
    b_force = std::max(b_force, st.bodies[1].contact_force_mn.norm());
    penetration = std::max(penetration, st.bodies[0].max_penetration_mm);
    if (k >= 300 && st.converged && rest_distance(body(t.world, t.a)) < 0.5 &&
        rest_distance(body(t.world, t.b)) < 0.1)
      break;
  }
  // The same press on the uncut pair: a slit away from where they meet changes little of what
  // reaches B.
  TwoSpheres uncut = two_spheres(0.5, 1.0, 0.3);
  attach(uncut, 30.0);
  double b_force_uncut = 0.0;
  for (int k = 0; k < 300; ++k) {
    step(uncut.world, st);
    b_force_uncut = std::max(b_force_uncut, st.bodies[1].contact_force_mn.norm());
  }
  std::printf(
      "cut: %lld tetrahedra, %d nodes added; B took %.0f mN (uncut %.0f mN), "
      "penetration %.3f mm; at rest at t = %.2f s: A %.3f mm from rest, B %.3f mm\n",
      static_cast<long long>(r.cut_tets), r.new_nodes, b_force, b_force_uncut, penetration,
      t.world.time_s, rest_distance(body(t.world, t.a)), rest_distance(body(t.world, t.b)));
  EXPECT_GT(b_force, 100.0) << "the cut body's press reaches its neighbour";
  EXPECT_NEAR(b_force, b_force_uncut, 0.25 * b_force_uncut);
  EXPECT_LE(penetration, 0.5);
  EXPECT_TRUE(body(t.world, t.a).sim.x.allFinite());
  EXPECT_LT(rest_distance(body(t.world, t.a)), 0.5);
  EXPECT_LT(rest_distance(body(t.world, t.b)), 0.1);
  EXPECT_EQ(count_ties(t.world).torn, 0);
}

// A scene's scalpel (world::advance_scalpels, `lamina run` of a world): it cuts A as it moves,
// a cut every mean edge, each through the world's renumbering: every tie keeps its two points.
TEST(CutBody, AScalpelMovingThroughABodyCutsItAsItGoesAndEveryTieKeepsItsPoints) {
  TwoSpheres t = two_spheres(0.5, 1.0, 0.3);
  const AttachmentId at = attach(t, 30.0);
  const size_t ties = attachment(t.world, at).ties.size();
  const Slit s = slit_into_a();
  interact::ScalpelDriver scalpels =
      interact::make_scalpel_driver({{.path = s.path,
                                      .depth_direction = s.direction,
                                      .depth_mm = s.depth_mm,
                                      .start_s = 0.05,
                                      .end_s = 0.25}},
                                    *body(t.world, t.a).model, "test");
  WorldStepStats st;
  int32_t cuts = 0;
  int64_t cut_tets = 0;
  double worst_tie_jump = 0.0;
  for (int k = 0; k < 2300; ++k) {
    // The ties' ends before the scalpel moves (it cuts from 0.05 to 0.25 s).
    const bool cutting = t.world.time_s > 0.04 && t.world.time_s < 0.26;
    const auto ends_before = cutting ? every_tie_end(t.world) : decltype(every_tie_end(t.world)){};
    const uint32_t topology = body(t.world, t.a).topology;
    for (const interact::CutEvent& e : advance_scalpels(t.world, t.a, scalpels)) {
      cuts += e.report.cut_tets > 0 ? 1 : 0;
      cut_tets += e.report.cut_tets;
    }
    const Body& a = body(t.world, t.a);
    if (a.topology != topology) {
      ASSERT_TRUE(cutting) << "a cut at t = " << t.world.time_s << " s";
      ASSERT_EQ(&a.sim.model(), a.model.get());
      ASSERT_EQ(a.rest_overlap_mm.size(), static_cast<size_t>(a.model->node_count()));
      const auto ends = every_tie_end(t.world);
      for (size_t j = 0; j < ends.size(); ++j)
        worst_tie_jump = std::max({worst_tie_jump, (ends[j].first - ends_before[j].first).norm(),
                                   (ends[j].second - ends_before[j].second).norm()});
    }
    step(t.world, st);
    ASSERT_EQ(st.unstable, sim::Instability::kNone) << "step " << k << ": " << st.unstable_body;
    if (k >= 300 && st.converged && rest_distance(body(t.world, t.a)) < 0.5 &&
        rest_distance(body(t.world, t.b)) < 0.1)
      break;  // at rest after the press (0.3 s) and the blade (0.25 s)
  }
  const Body& a = body(t.world, t.a);
  std::printf(
      "a moving scalpel: %d cuts, %lld tetrahedra, A %d nodes; at rest at t = %.2f s, A %.3f mm "
      "from rest\n",
      cuts, static_cast<long long>(cut_tets), a.model->node_count(), t.world.time_s,
      rest_distance(a));
  EXPECT_GE(cuts, 3) << "the blade cuts as it goes, not once at its end";
  EXPECT_EQ(a.topology, static_cast<uint32_t>(cuts));
  EXPECT_EQ(body(t.world, t.b).topology, 0u);
  EXPECT_LT(worst_tie_jump, 1e-9) << "a tie moved when its body was renumbered";
  EXPECT_EQ(attachment(t.world, at).ties.size(), ties);
  EXPECT_EQ(count_ties(t.world).torn, 0);
  EXPECT_EQ(sim::inverted_tets(*a.model, a.sim.x), 0);
  EXPECT_LT(rest_distance(a), 0.5);
  EXPECT_LT(rest_distance(body(t.world, t.b)), 0.1);
  EXPECT_THROW(advance_scalpels(t.world, BodyId{t.a.index, t.a.generation + 1}, scalpels), Error);
}

TEST(CutBody, ABladeThatMissesChangesNothingAndBadCallsAreRefusedWithNothingChanged) {
  TwoSpheres t = two_spheres(0.5, 0.0, 0.0);
  attach(t, 30.0);
  const auto ends_before = every_tie_end(t.world);
  const Model* model_before = body(t.world, t.a).model.get();
  Slit far = slit_into_a();
  for (Eigen::Vector3d& p : far.path) p.z() += 200.0;  // high above both
  far.depth_mm = 10.0;
  EXPECT_EQ(cut_body(t.world, t.a, far.path, far.direction, far.depth_mm).cut_tets, 0);

  const Slit s = slit_into_a();
  const BodyId stale{t.a.index, t.a.generation + 1};
  EXPECT_THROW(cut_body(t.world, stale, s.path, s.direction, s.depth_mm), Error);
  EXPECT_THROW(cut_body(t.world, t.a, {s.path[0]}, s.direction, s.depth_mm), Error);
  EXPECT_THROW(cut_body(t.world, t.a, s.path, s.direction, -1.0), Error);
  EXPECT_THROW(cut_body(t.world, t.a, s.path, Eigen::Vector3d::Zero(), s.depth_mm), Error);
  EXPECT_EQ(body(t.world, t.a).model.get(), model_before);
  EXPECT_EQ(body(t.world, t.a).topology, 0u);
  const auto ends = every_tie_end(t.world);
  for (size_t k = 0; k < ends.size(); ++k) EXPECT_EQ(ends[k].first, ends_before[k].first);
}

TEST(WorldLoop, ACutRenumbersTheBodyRefusesItsOldNodesAndAResetPutsItBackUncut) {
  TwoSpheres t = two_spheres(0.5, 0.0, 0.0);
  attach(t, 30.0);
  const int32_t nodes_before = body(t.world, t.a).model->node_count();
  const int32_t a_node = skin_node_with_least_x(*body(t.world, t.a).model);
  WorldLoop loop(std::move(t.world), {.real_time = false});
  const auto h = loop.bodies();
  ASSERT_EQ(h.size(), 2u);
  const interact::LiveForce pull{.node = a_node, .force_mn = Eigen::Vector3d(0, 0, 50)};
  loop.set_forces(h[0].first, h[0].second, {pull});
  loop.set_forces(h[1].first, h[1].second, {{.node = 0, .force_mn = Eigen::Vector3d(0, 0, 50)}});
  loop.run_steps(10);
  WorldSnapshot snap;
  ASSERT_TRUE(loop.latest(snap));
  const Eigen::Vector3d pulled_at = snap.bodies[0].x.row(a_node).transpose();

  const Slit s = slit_into_a();
  loop.cut(s.path, s.direction, s.depth_mm);
  loop.run_steps(1);
  ASSERT_TRUE(loop.latest(snap));
  EXPECT_EQ(snap.cuts, 1);
  EXPECT_GT(snap.tets_cut, 0);
  EXPECT_TRUE(snap.cut_message.empty()) << snap.cut_message;
  EXPECT_EQ(snap.bodies[0].topology, 1u);
  EXPECT_EQ(snap.bodies[1].topology, 0u);
  EXPECT_GT(snap.bodies[0].model->node_count(), nodes_before);
  // A's pull goes on, on its node's first copy: a skin node of the new numbering, where the
  // node was (one step on), and the drag still lifts it.
  ASSERT_EQ(snap.bodies[0].force_nodes.size(), 1u) << "the cut released A's pull";
  const int32_t carried = snap.bodies[0].force_nodes[0];
  EXPECT_LT(carried, snap.bodies[0].model->layers[0].node_count);
  EXPECT_LT((snap.bodies[0].x.row(carried).transpose() - pulled_at).norm(), 0.5);
  EXPECT_EQ(snap.bodies[1].force_nodes.size(), 1u) << "B, not cut, keeps its force";
  loop.run_steps(9);
  ASSERT_TRUE(loop.latest(snap));
  EXPECT_GT(snap.bodies[0].x(carried, 2), pulled_at.z() + 0.01) << "the pull stopped at the cut";
  EXPECT_EQ(snap.unstable, sim::Instability::kNone);
  // Nodes of the old generation are refused; of the new one taken.
  EXPECT_THROW(loop.set_forces(h[0].first, 0, {pull}), Error);
  loop.set_forces(h[0].first, 1, {pull});

  // A blade that meets no tissue says so.
  Slit far = s;
  for (Eigen::Vector3d& p : far.path) p.z() += 200.0;
  loop.cut(far.path, far.direction, 10.0);
  loop.run_steps(1);
  ASSERT_TRUE(loop.latest(snap));
  EXPECT_EQ(snap.cuts, 1);
  EXPECT_FALSE(snap.cut_message.empty());

  loop.reset();
  loop.run_steps(1);
  ASSERT_TRUE(loop.latest(snap));
  EXPECT_EQ(snap.bodies[0].model->node_count(), nodes_before) << "reset puts A back uncut";
  EXPECT_EQ(snap.bodies[0].topology, 2u);
  EXPECT_EQ(snap.bodies[1].topology, 0u);
  EXPECT_EQ(snap.cuts, 0);
  EXPECT_EQ(snap.tie_count.divided, 0);
  EXPECT_TRUE(snap.bodies[0].force_nodes.empty());
  EXPECT_EQ(snap.bodies[1].force_nodes.size(), 1u);
  loop.run_steps(200);
  ASSERT_TRUE(loop.latest(snap));
  EXPECT_EQ(snap.unstable, sim::Instability::kNone);
  EXPECT_TRUE(snap.bodies[0].x.allFinite());
}

// An undo carries a cut body's live forces back to the nodes their copies came from, as the
// one-organ loop's undo gives the forces back: the pull goes on across the cut and its undo.
TEST(WorldLoop, AnUndoCarriesTheForcesBackToTheNodesTheyCameFrom) {
  TwoSpheres t = two_spheres(0.5, 0.0, 0.0);
  attach(t, 30.0);
  const int32_t a_node = skin_node_with_least_x(*body(t.world, t.a).model);
  WorldLoop loop(std::move(t.world), {.real_time = false});
  const auto h = loop.bodies();
  loop.set_forces(h[0].first, h[0].second,
                  {{.node = a_node, .force_mn = Eigen::Vector3d(0, 0, 50)}});
  loop.run_steps(10);
  const Slit s = slit_into_a();
  loop.cut(s.path, s.direction, s.depth_mm);
  loop.run_steps(1);
  WorldSnapshot snap;
  ASSERT_TRUE(loop.latest(snap));
  ASSERT_EQ(snap.bodies[0].topology, 1u);
  ASSERT_EQ(snap.bodies[0].force_nodes.size(), 1u);

  loop.undo_cut();
  loop.run_steps(1);
  ASSERT_TRUE(loop.latest(snap));
  EXPECT_EQ(snap.cuts, 0);
  EXPECT_EQ(snap.bodies[0].topology, 2u);
  ASSERT_EQ(snap.bodies[0].force_nodes.size(), 1u) << "the undo let the pull go";
  EXPECT_EQ(snap.bodies[0].force_nodes[0], a_node) << "not back on the node it was set on";
  // The pull goes on as if there had been no cut: 150 steps on, the node as lifted as on an uncut
  // twin pulled as long (released, it would come back within 0.3 mm: ACutRenumbers... above).
  loop.run_steps(150);
  ASSERT_TRUE(loop.latest(snap));
  TwoSpheres u = two_spheres(0.5, 0.0, 0.0);
  attach(u, 30.0);
  WorldLoop twin(std::move(u.world), {.real_time = false});
  twin.set_forces(h[0].first, h[0].second,
                  {{.node = a_node, .force_mn = Eigen::Vector3d(0, 0, 50)}});
  twin.run_steps(161);
  WorldSnapshot ref;
  ASSERT_TRUE(twin.latest(ref));
  const auto lifted = [&](const WorldSnapshot& w) {
    return w.bodies[0].x(a_node, 2) - w.bodies[0].model->X(a_node, 2);
  };
  std::printf("lifted %.3f mm after the cut and its undo, %.3f mm uncut\n", lifted(snap),
              lifted(ref));
  ASSERT_GT(lifted(ref), 0.5);
  EXPECT_NEAR(lifted(snap), lifted(ref), 0.1 * lifted(ref)) << "the pull stopped at the undo";
  EXPECT_EQ(snap.unstable, sim::Instability::kNone);
}

// A running loop's cut is made on another thread while the world steps on, and taken in between
// two steps: the stepping thread's pause is a small part of the cut's making, the world steps
// on meanwhile, the body is cut as run_steps() cuts it, and a pull held on the other body is
// kept.
TEST(WorldLoop, ARunningLoopCutsOnAnotherThreadWhileTheWorldStepsOn) {
  TwoSpheres t = two_spheres(0.5, 0.0, 0.0);
  TwoSpheres u = two_spheres(0.5, 0.0, 0.0);
  const Slit s = slit_into_a();
  // The reference: the same cut made between two steps of a loop without its thread.
  WorldLoop waited(std::move(u.world), {.real_time = false});
  waited.cut(s.path, s.direction, s.depth_mm);
  waited.run_steps(1);
  WorldSnapshot ref;
  ASSERT_TRUE(waited.latest(ref));
  ASSERT_EQ(ref.cuts, 1);

  WorldLoop loop(std::move(t.world), {.rate_hz = 1000.0});
  const auto h = loop.bodies();
  loop.set_forces(h[1].first, h[1].second, {{.node = 0, .force_mn = Eigen::Vector3d(0, 0, 50)}});
  loop.start();
  WorldSnapshot snap;
  for (int k = 0; k < 200 && snap.steps < 20; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    loop.latest(snap);
  }
  const int64_t steps_at_stroke = snap.steps;
  loop.cut(s.path, s.direction, s.depth_mm);
  for (int k = 0; k < 2000 && snap.cuts == 0; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    loop.latest(snap);
  }
  loop.stop();
  ASSERT_EQ(snap.cuts, 1) << snap.cut_message;
  std::printf(
      "cut on another thread: the stepping thread's pause %.2f ms of %.2f ms, %lld steps "
      "meanwhile\n",
      snap.last_cut_ms, snap.last_cut_made_ms,
      static_cast<long long>(snap.last_cut_steps_meanwhile));
  EXPECT_EQ(snap.unstable, sim::Instability::kNone);
  EXPECT_EQ(snap.bodies[0].topology, 1u);
  EXPECT_EQ(snap.bodies[0].model->node_count(), ref.bodies[0].model->node_count());
  EXPECT_EQ(snap.tets_cut, ref.tets_cut);
  EXPECT_EQ(snap.bodies[1].force_nodes.size(), 1u) << "B's pull was dropped";
  EXPECT_GT(snap.last_cut_made_ms, 0.0);
  EXPECT_LT(snap.last_cut_ms, 0.5 * snap.last_cut_made_ms)
      << "the stepping thread waited for the whole cut";
  EXPECT_GT(snap.last_cut_steps_meanwhile, 0) << "the world did not step while the cut was made";
  EXPECT_GT(snap.steps, steps_at_stroke);
  EXPECT_TRUE(snap.bodies[0].x.allFinite());
}

}  // namespace
}  // namespace lamina::world
