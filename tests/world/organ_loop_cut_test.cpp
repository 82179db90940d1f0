// The one-organ loop's cuts (organ_loop.h; the viewer's K, serve's scalpel, the C API's): made
// between two steps, or on another thread while the loop steps on; the live forces carried to
// the copies of their nodes and back by an undo; the parameters set since a cut kept by its undo.
#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <thread>

#include "lamina/core/error.h"
#include "lamina/world/organ_loop.h"
#include "support/phantom_across.h"
#include "support/tet_phantom.h"

namespace {

using namespace lamina;
using test::across;
using test::Across;

sim::Simulation held() {
  return test::held_phantom();
}

// The skin node farthest to the front (least y) 15 mm left of the cut: a force there pushes
// the piece the cut leaves whole.
int32_t front_node_left_of(const Model& m, const Across& a) {
  int32_t node = -1;
  for (int32_t i = 0; i < m.layers[0].node_count; ++i)
    if (m.X(i, 0) < a.x0 - 15 && (node < 0 || m.X(i, 1) < m.X(node, 1))) node = i;
  return node;
}

// The realtime loop (the viewer's, the server's, the C API's) cuts between two steps: the model
// it publishes is the cut one, a live force keeps acting on the copies of its node, and the
// pieces come apart.
TEST(OrganLoopCut, ItCutsBetweenTwoStepsItsForcesCarryOverAndItUndoes) {
  const Model& m = test::tet_phantom();
  const Across a = across();
  sim::Simulation s = held();
  world::OrganLoop loop(std::move(s),
                        {.routing = interact::Routing::kNone, .touch = interact::Touch::kSkin},
                        {.real_time = false});
  const int32_t node = front_node_left_of(m, a);
  loop.set_forces({{.node = node, .force_mn = Eigen::Vector3d(0, 30, 0)}});
  loop.run_steps(20);
  world::LoopSnapshot before;
  ASSERT_TRUE(loop.latest(before));
  EXPECT_EQ(before.model_version, 0u);
  EXPECT_EQ(before.model.get(), &m);
  EXPECT_THROW(loop.cut({a.scalpel.path[0]}, Eigen::Vector3d::UnitZ(), 10.0), Error);

  loop.cut(a.scalpel.path, a.scalpel.depth_direction, a.scalpel.depth_mm);
  loop.run_steps(20);
  world::LoopSnapshot after;
  ASSERT_TRUE(loop.latest(after));
  ASSERT_EQ(after.model_version, 1u);
  ASSERT_TRUE(after.model);
  EXPECT_EQ(after.cuts, 1);
  EXPECT_EQ(after.cut_error, "");
  EXPECT_EQ(after.last_cut.pieces.size(), 2u);
  EXPECT_GT(after.model->node_count(), m.node_count());
  ASSERT_EQ(after.x.rows(), after.model->node_count());
  EXPECT_TRUE(after.x.allFinite());
  // The force acts on the node's copy, on the new model's skin, where it acted.
  ASSERT_EQ(after.contact_nodes.size(), 1u);
  const int32_t at = after.contact_nodes[0];
  ASSERT_GE(at, 0);
  ASSERT_LT(at, after.model->layers[0].node_count);
  EXPECT_LT((after.model->X.row(at) - m.X.row(node)).norm(), 10.0);
  EXPECT_GT(after.x(at, 1) - after.model->X(at, 1), before.x(node, 1) - m.X(node, 1))
      << "the force stopped pushing";
  EXPECT_EQ(after.undoable, 1);

  // Undone: the model the loop was made with, the force on its node again, the clock running on.
  loop.undo_cut();
  loop.run_steps(20);
  world::LoopSnapshot undone;
  ASSERT_TRUE(loop.latest(undone));
  EXPECT_EQ(undone.model_version, 2u);
  ASSERT_TRUE(undone.model);  // the loop's own copy of the model it was made with
  EXPECT_EQ(undone.model->node_count(), m.node_count());
  EXPECT_EQ(undone.model->X, m.X);
  EXPECT_EQ(undone.cuts, 0);
  EXPECT_EQ(undone.undoable, 0);
  EXPECT_EQ(undone.cut_error, "");
  ASSERT_EQ(undone.x.rows(), m.node_count());
  EXPECT_TRUE(undone.x.allFinite());
  EXPECT_GT(undone.time_s, after.time_s);
  ASSERT_EQ(undone.contact_nodes.size(), 1u);
  EXPECT_EQ(undone.contact_nodes[0], node);
  EXPECT_GT(undone.x(node, 1) - m.X(node, 1), 0.0) << "the force stopped pushing";
  // Nothing more to undo: said, nothing changed.
  loop.undo_cut();
  loop.run_steps(1);
  world::LoopSnapshot none;
  ASSERT_TRUE(loop.latest(none));
  EXPECT_EQ(none.model_version, 2u);
  EXPECT_EQ(none.cut_error, "undo: there is no cut to undo");
  EXPECT_EQ(none.x.rows(), m.node_count());
}

// An undo takes the organ back as it was before the cut, but not its parameters: a material or
// solver set since the cut is kept (the panel shows what steps), as the world's undo keeps it.
TEST(OrganLoopCut, AnUndoKeepsTheParametersSetSinceTheCut) {
  const Model& m = test::tet_phantom();
  const Across a = across();
  const interact::RoutingOptions routing{.routing = interact::Routing::kNone,
                                         .touch = interact::Touch::kSkin};
  world::OrganLoop loop(held(), routing, {.real_time = false});
  const int32_t node = front_node_left_of(m, a);
  loop.set_forces({{.node = node, .force_mn = Eigen::Vector3d(0, 100, 0)}});
  loop.run_steps(200);
  world::LoopSnapshot soft;
  ASSERT_TRUE(loop.latest(soft));
  const double soft_dent = soft.x(node, 1) - m.X(node, 1);
  ASSERT_GT(soft_dent, 0.5);
  EXPECT_EQ(soft.material.young_modulus_kpa, test::kTetLiver.young_modulus_kpa);

  loop.cut(a.scalpel.path, a.scalpel.depth_direction, a.scalpel.depth_mm);
  loop.run_steps(5);
  sim::Material stiff = soft.material;
  stiff.young_modulus_kpa *= 4.0;
  sim::SolverOptions solver = soft.solver;
  solver.cg_tolerance = 1e-7;
  loop.set_parameters(stiff, solver, routing);
  loop.run_steps(5);
  loop.undo_cut();
  loop.run_steps(300);
  world::LoopSnapshot undone;
  ASSERT_TRUE(loop.latest(undone));
  ASSERT_EQ(undone.cuts, 0);
  ASSERT_EQ(undone.x.rows(), m.node_count());
  EXPECT_EQ(undone.material.young_modulus_kpa, stiff.young_modulus_kpa) << "E of before the cut";
  EXPECT_EQ(undone.solver.cg_tolerance, 1e-7);
  // Four times as stiff, the same force dents it about a quarter as deep.
  const double stiff_dent = undone.x(node, 1) - m.X(node, 1);
  EXPECT_GT(stiff_dent, 0.0);
  EXPECT_LT(stiff_dent, 0.5 * soft_dent) << "the undone organ steps with the old material";
}

// A running loop makes its cuts on another thread and goes on stepping meanwhile: the cut it
// takes in is the one run_steps() makes (the same model, node for node), the organ's motion
// carried over to it at the moment it is taken in; an undo asked for while the cut is being
// made waits for it and then takes it back; the stepping thread's part is reported.
TEST(OrganLoopCut, ARunningLoopCutsOnAnotherThreadAsBetweenTwoStepsAndAnUndoWaitsForIt) {
  const Model& m = test::tet_phantom();
  const Across a = across();
  const interact::RoutingOptions routing{.routing = interact::Routing::kNone,
                                         .touch = interact::Touch::kSkin};
  world::OrganLoop reference(held(), routing, {.real_time = false});
  reference.run_steps(5);
  reference.cut(a.scalpel.path, a.scalpel.depth_direction, a.scalpel.depth_mm);
  reference.run_steps(1);
  world::LoopSnapshot expected;
  ASSERT_TRUE(reference.latest(expected));
  ASSERT_EQ(expected.cuts, 1);

  world::OrganLoop loop(held(), routing, {.rate_hz = 200.0});
  loop.start();
  const auto wait_for = [&](const std::function<bool(const world::LoopSnapshot&)>& done) {
    world::LoopSnapshot snap;
    for (int k = 0; k < 3000; ++k) {
      loop.latest(snap);
      if (done(snap)) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return snap;
  };
  const int64_t asked_at = wait_for([](const auto& s) { return s.steps >= 5; }).steps;
  loop.cut(a.scalpel.path, a.scalpel.depth_direction, a.scalpel.depth_mm);
  loop.undo_cut();  // asked before the cut is in: it waits for it
  const world::LoopSnapshot undone = wait_for([](const auto& s) { return s.model_version >= 2; });
  loop.stop();
  ASSERT_EQ(undone.model_version, 2u) << undone.cut_error;
  EXPECT_EQ(undone.cuts, 0);
  EXPECT_EQ(undone.cut_error, "");
  EXPECT_EQ(undone.model->node_count(), m.node_count());
  EXPECT_EQ(undone.x.rows(), m.node_count());
  EXPECT_TRUE(undone.x.allFinite());
  EXPECT_GT(undone.steps, asked_at);
  EXPECT_GT(undone.longest_cut_pause_us, 0.0);

  // Cut again, and this time kept: the model run_steps() made.
  loop.start();
  loop.cut(a.scalpel.path, a.scalpel.depth_direction, a.scalpel.depth_mm);
  const world::LoopSnapshot cut = wait_for([](const auto& s) { return s.model_version >= 3; });
  loop.stop();
  ASSERT_EQ(cut.cuts, 1) << cut.cut_error;
  EXPECT_EQ(cut.last_cut.cut_tets, expected.last_cut.cut_tets);
  EXPECT_EQ(cut.last_cut.pieces.size(), expected.last_cut.pieces.size());
  ASSERT_EQ(cut.model->node_count(), expected.model->node_count());
  EXPECT_EQ(cut.model->X, expected.model->X);
  EXPECT_EQ(cut.model->tets.T, expected.model->tets.T);
  ASSERT_EQ(cut.x.rows(), cut.model->node_count());
  // At rest and held, the organ stays where it was: the state carried over node for node.
  EXPECT_LT((cut.x - cut.model->X).cwiseAbs().maxCoeff(), 1e-6);
}

}  // namespace
