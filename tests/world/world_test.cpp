// A world of bodies: contact conserves force and holds a 2 N press within 0.5 mm, the bodies
// come back to rest, one body steps exactly as its simulation alone, stale handles and
// overlapping bodies are refused, attachments hold, tear and are divided.
#include "lamina/world/world.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>

#include "lamina/core/error.h"
#include "lamina/sim/contact_springs.h"
#include "world/two_spheres.h"
#include "world/world_work.h"

namespace lamina::world {
namespace {

using namespace test_world;

// Spheres of 60 mm (the test sphere scaled 3x: nodes of about half a gram, as an organ's at
// the paper's size), A pressed onto B with 2 N for 1.5 s, then released.
TEST(World, ContactHoldsATwoNewtonPressWithinHalfAMillimetreForceConservedAndComesBackToRest) {
  TwoSpheres t = two_spheres(0.5, 2.0, 1.5, 3.0);
  WorldStepStats st;
  double worst_penetration = 0.0;
  for (int k = 0; k < 1500; ++k) {
    step(t.world, st);
    ASSERT_EQ(st.unstable, sim::Instability::kNone) << "step " << k << ": " << st.unstable_body;
    for (const BodyStepStats& b : st.bodies)
      worst_penetration = std::max(worst_penetration, b.max_penetration_mm);
  }
  EXPECT_LE(worst_penetration, 0.5);
  // Pressed and settled: B takes what A's own support does not, the press's direction equal
  // and opposite within 1% (docs/world.md: the sideways share, a slow creep, is not yet).
  const Eigen::Vector3d fa = st.bodies[0].contact_force_mn, fb = st.bodies[1].contact_force_mn;
  EXPECT_GT(fb.x(), 500.0);
  EXPECT_LT(fb.x(), 2000.0);
  EXPECT_LE(std::abs(fa.x() + fb.x()), 0.01 * std::abs(fa.x()));
  EXPECT_LT(std::max(st.bodies[0].sim.max_speed_mm_per_s, st.bodies[1].sim.max_speed_mm_per_s), 2.0)
      << "the pressed pair does not come to rest";
  for (int k = 0; k < 3000; ++k) {
    step(t.world, st);
    ASSERT_EQ(st.unstable, sim::Instability::kNone);
  }
  std::printf("released: A %.3f mm, B %.3f mm from rest\n", rest_distance(body(t.world, t.a)),
              rest_distance(body(t.world, t.b)));
  // B, fixed, is back within 0.05 mm; A, held only by a weak support on its far cap, is still
  // creeping back 3 s after release (docs/world.md).
  EXPECT_LT(rest_distance(body(t.world, t.b)), 0.05);
  EXPECT_LT(rest_distance(body(t.world, t.a)), 0.25);
}

// The step's search reads near lists (each node that could reach a skin, with the triangles it
// could reach), made again as the skins move: while A is pressed onto B (contacts coming and
// staying) and after, the contacts found are exactly those a search of every node finds.
TEST(World, TheContactSearchSkipsOnlyNodesThatCannotReachASkin) {
  // A starts 9 mm away: the nodes that touch B were on no list at the start.
  TwoSpheres t = two_spheres(9.0, 4.0, 1.5, 3.0);
  WorldStepStats st;
  const auto found = [&](bool every_node) {
    detail::find_contacts(t.world, /*measure_rest=*/false, every_node);
    std::set<std::array<int32_t, 3>> out;
    for (const Contact& c : t.world.work().contacts) out.insert({c.body, c.node, c.other});
    return out;
  };
  int64_t compared = 0;
  for (int k = 0; k <= 900; ++k) {
    step(t.world, st);
    if (k % 60 != 0) continue;
    const auto skipping = found(false), all = found(true);
    EXPECT_EQ(skipping, all) << "step " << k;
    compared += static_cast<int64_t>(all.size());
  }
  EXPECT_GT(compared, 50);  // contacts were there to find
  // The lists were made again while A moved (not only once at the start), and the nodes far from
  // any skin were left off them.
  int64_t made = 0;
  size_t listed = 0;
  for (const detail::NearLists& l : t.world.work().near) {
    made += l.made;
    listed = std::max(listed, l.nodes.size());
  }
  EXPECT_GT(made, 4);
  EXPECT_GT(listed, 0u);
  EXPECT_LT(listed, static_cast<size_t>(body(t.world, t.a).model->layers.front().node_count / 2));
}

TEST(World, OneBodyStepsExactlyAsItsSimulationAlone) {
  const Eigen::Vector3d c = sphere_centre();
  auto m = sphere_at(Eigen::Vector3d::Zero());
  const interact::ToolDriver poke{
      .tools = {{.vertex = skin_node_with_least_x(*m),
                 .force_mn = Eigen::Vector3d(300.0, 0.0, 0.0),
                 .end_s = 0.05}},
      .routing = {.routing = interact::Routing::kNone, .touch = interact::Touch::kSkin}};
  sim::Simulation alone = tissue_on(*m);
  sim::fix_nodes(alone, cap(*m, c.x() + 12.0, +1.0));
  sim::Simulation in_world = alone;
  interact::ToolDriver driver = poke;
  World world;
  const BodyId id = create_body(
      world, {.name = "organ", .model = m, .simulation = std::move(in_world), .tools = poke});
  for (int k = 0; k < 120; ++k) {
    interact::apply_tools(alone, driver);
    sim::step(alone);
    step(world);
  }
  const Body& b = body(world, id);
  EXPECT_EQ((b.sim.x - alone.x).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((b.sim.v - alone.v).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_GT(rest_distance(b), 0.1);  // it did move
}

TEST(World, StaleHandlesAndOverlappingBodiesAreRefusedLeavingTheWorldAsItWas) {
  TwoSpheres t = two_spheres(0.5, 0.0, 0.0);
  destroy_body(t.world, t.b);
  EXPECT_FALSE(is_valid(t.world, t.b));
  try {
    (void)body(t.world, t.b);
    FAIL() << "a stale handle was taken";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("stale"), std::string::npos) << e.what();
  }
  EXPECT_THROW(destroy_body(t.world, t.b), Error);
  // The slot is reused by the next body, under a new generation: the old handle stays stale.
  auto mc = sphere_at(Eigen::Vector3d(40.5, 0.0, 0.0));
  const BodyId c =
      create_body(t.world, {.name = "c", .model = mc, .simulation = tissue_on(*mc), .tools = {}});
  EXPECT_EQ(c.index, t.b.index);
  EXPECT_FALSE(is_valid(t.world, t.b));
  EXPECT_THROW(create_attachment(t.world, {.body_a = t.a.index,
                                           .body_b = t.b.index,
                                           .generation_a = t.a.generation,
                                           .generation_b = t.b.generation}),
               Error);
  // A body placed half inside another is refused, naming both.
  auto md = sphere_at(Eigen::Vector3d(20.0, 0.0, 0.0));
  try {
    create_body(t.world, {.name = "d", .model = md, .simulation = tissue_on(*md), .tools = {}});
    FAIL() << "an overlapping body was taken";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("'d'"), std::string::npos) << what;
    EXPECT_NE(what.find("overlap"), std::string::npos) << what;
  }
  EXPECT_EQ(body_ids(t.world).size(), 2u);
  EXPECT_EQ(find_body(t.world, "d").index, -1);
}

TEST(World, AttachmentsHoldConserveForceAndTearPastTheirStrength) {
  double moved[2] = {0.0, 0.0};
  int run = 0;
  for (const double strength : {1000.0, 5.0}) {
    // A (supported on its far cap) pulled away from B (fixed far side) by 1 N.
    TwoSpheres t = two_spheres(0.5, -1.0, 10.0);
    const AttachmentId id = attach(t, strength);
    const int64_t ties = count_ties(t.world).total;
    ASSERT_GT(ties, 10);
    WorldStepStats st;
    for (int k = 0; k < 600; ++k) {
      step(t.world, st);
      ASSERT_EQ(st.unstable, sim::Instability::kNone);
    }
    const Attachment& at = attachment(t.world, id);
    const auto torn =
        std::count_if(at.ties.begin(), at.ties.end(), [](const Tie& x) { return x.torn; });
    moved[run++] = rest_distance(body(t.world, t.a));
    if (strength > 100.0) {
      // Held, and once settled what one body receives the other gives (each spring's far end
      // gets its force a step later).
      const Eigen::Vector3d fa = st.bodies[0].attachment_force_mn,
                            fb = st.bodies[1].attachment_force_mn;
      EXPECT_GT(fa.norm(), 100.0);
      EXPECT_LE((fa + fb).norm(), 0.01 * fa.norm());
      EXPECT_EQ(torn, 0) << "strong ties tore";
    } else {
      EXPECT_EQ(torn, ties) << "weak ties held a 1 N pull";
      EXPECT_EQ(st.bodies[0].attachment_force_mn.norm(), 0.0);
    }
  }
  EXPECT_GT(moved[1], moved[0] + 2.0) << "A came away no farther once its ties tore";
}

TEST(World, ABladeBetweenTheBodiesDividesTheirTies) {
  TwoSpheres t = two_spheres(0.5, 0.0, 0.0);
  attach(t, 30.0);
  const Eigen::Vector3d c = sphere_centre();
  const double x = c.x() + 20.25;  // the plane between them
  // A blade edge along z swept along y through the whole contact.
  const BladeSweep half{.a0 = {x, c.y() - 30.0, c.z() - 30.0},
                        .b0 = {x, c.y() - 30.0, c.z() + 30.0},
                        .a1 = {x, c.y(), c.z() - 30.0},
                        .b1 = {x, c.y(), c.z() + 30.0}};
  const int32_t first = divide_ties(t.world, half);
  const TieCount after_half = count_ties(t.world);
  EXPECT_GT(first, 0);
  EXPECT_LT(after_half.divided, after_half.total);  // only the half the blade passed
  BladeSweep rest = half;
  rest.a0 = half.a1;
  rest.b0 = half.b1;
  rest.a1.y() = rest.b1.y() = c.y() + 30.0;
  divide_ties(t.world, rest);
  EXPECT_EQ(count_ties(t.world).divided, count_ties(t.world).total);
  // Divided, they pull no more.
  WorldStepStats st;
  step(t.world, st);
  EXPECT_EQ(st.bodies[0].attachment_force_mn.norm(), 0.0);
}

}  // namespace
}  // namespace lamina::world

namespace lamina::world {
namespace {

using namespace test_world;

// The couplings' spring: stiffness inside the implicit step plus its constant force holds a node
// at a point, stably at a stiffness far beyond an explicit force's reach, and lets go when
// cleared.
TEST(World, AContactSpringHoldsANodeAtItsPointInsideTheImplicitStepAndLetsGo) {
  const Eigen::Vector3d c = sphere_centre();
  auto m = sphere_at(Eigen::Vector3d::Zero());
  sim::Simulation s = tissue_on(*m);
  sim::fix_nodes(s, cap(*m, c.x() + 12.0, +1.0));
  const int32_t n = skin_node_with_least_x(*m);
  const Eigen::Vector3d target = m->X.row(n).transpose() - Eigen::Vector3d(3.0, 0.0, 0.0);
  const double k = 1e5;  // N/m: k dt^2 / m of about 6000 on this node
  sim::set_contact_stiffness(s, {n}, {k});
  s.f_ext.row(n) = (k * (target - m->X.row(n).transpose())).transpose();
  const sim::StepStats held = sim::run_to_convergence(s);
  EXPECT_EQ(held.unstable, sim::Instability::kNone);
  EXPECT_TRUE(held.converged);
  EXPECT_LT((s.x.row(n).transpose() - target).norm(), 0.01);
  sim::set_contact_stiffness(s, {}, {});
  s.f_ext.setZero();
  const sim::StepStats released = sim::run_to_convergence(s);
  EXPECT_TRUE(released.converged);
  EXPECT_LT((s.x - m->X).rowwise().norm().maxCoeff(), 0.05);
  EXPECT_THROW(sim::set_contact_stiffness(s, {n}, {-1.0}), Error);
  EXPECT_THROW(sim::set_contact_stiffness(s, {m->node_count()}, {1.0}), Error);
}

}  // namespace
}  // namespace lamina::world
