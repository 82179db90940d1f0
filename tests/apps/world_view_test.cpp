// `lamina view` of a world (apps/lamina/view/world_view.h) on the viewer engine's mock backend:
// two spheres tied where they meet. Both are drawn, the ties as beads; a drag on one body dents
// it and, released, it returns to rest; a dissection drag across their meeting divides the ties
// it passes; R puts them back; the report says what happened. The world steps at 100 Hz (10 ms
// steps) and the tests wait on simulated time.
#include "world_view.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "lamina/render/camera.h"
#include "lamina/render/viewer.h"
#include "support/session_frames.h"
#include "world/two_spheres.h"

namespace lamina::cli {
namespace {

using render::InputEvent;
using render::MouseButton;
using ::testing::HasSubstr;

std::unique_ptr<WorldViewSession> tied_spheres() {
  auto ready = std::make_unique<io::ReadyWorld>();
  world::test_world::TwoSpheres t = world::test_world::two_spheres(0.5, 0.0, 0.0);
  world::test_world::attach(t, 30.0);
  ready->world = std::move(t.world);
  io::WorldScene scene;
  scene.source = "two tied spheres";
  // 100 Hz: real time's 10 ms steps (the bodies' own are 1 ms), so that the seconds of simulated
  // time the tests wait for are a few hundred steps even under the sanitizers.
  return std::make_unique<WorldViewSession>(
      WorldViewOptions{.rate_hz = 100.0, .gain_n_per_mm = 0.05}, std::move(scene),
      std::move(ready));
}

using test::frames_until;
using test::simulate_for;
using test::simulate_until_rest;

double moved(const world::BodyView& b) {
  return (b.x - b.model->X).rowwise().norm().maxCoeff();
}

// The pixel whose ray passes nearest to `p` (a scan, then a finer one around the best).
Eigen::Vector2d pixel_of(const Eigen::Vector3d& p) {
  const Eigen::Vector2i size = render::window_size();
  const auto off = [&](double x, double y) {
    const render::Ray r = render::pixel_ray(render::camera(), size.x(), size.y(), x, y);
    const Eigen::Vector3d d = p - r.origin;
    return (d - d.dot(r.direction) * r.direction).norm();
  };
  Eigen::Vector2d best(0, 0);
  for (double step : {8.0, 1.0}) {
    const Eigen::Vector2d around = best;
    const double span = step == 8.0 ? std::max(size.x(), size.y()) : 8.0;
    for (double x = std::max(0.0, around.x() - span);
         x <= std::min<double>(size.x(), around.x() + span); x += step)
      for (double y = std::max(0.0, around.y() - span);
           y <= std::min<double>(size.y(), around.y() + span); y += step)
        if (off(x, y) < off(best.x(), best.y())) best = {x, y};
  }
  return best;
}

// `key` pressed, then a left drag straight down from `span` px above `m` to `span` px below it,
// 10 px a frame, released.
void stroke_down(WorldViewSession& s, const std::string& key, const Eigen::Vector2d& m,
                 double span) {
  render::inject(InputEvent::key_down(key));
  render::inject(InputEvent::key_up(key));
  s.frame();
  render::inject(InputEvent::move_to(m - Eigen::Vector2d(0, span)));
  s.frame();
  render::inject(InputEvent::press(MouseButton::kLeft));
  s.frame();
  for (double y = -span + 10.0; y <= span; y += 10.0) {
    render::inject(InputEvent::move_to(m + Eigen::Vector2d(0, y)));
    s.frame();
  }
  render::inject(InputEvent::release(MouseButton::kLeft));
  s.frame();
}

// A left press at `at` and five moves of `step` from it, a frame each (held: the caller releases).
void drag_from(WorldViewSession& s, const Eigen::Vector2d& at, const Eigen::Vector2d& step) {
  render::inject(InputEvent::move_to(at));
  s.frame();
  render::inject(InputEvent::press(MouseButton::kLeft));
  s.frame();
  for (int i = 1; i <= 5; ++i) {
    render::inject(InputEvent::move_to(at + i * step));
    s.frame();
  }
}

class WorldViewTest : public ::testing::Test {
 protected:
  void SetUp() override { render::init({.backend = render::Backend::kMock}); }
  void TearDown() override { render::shutdown(); }
};

TEST_F(WorldViewTest, BothBodiesAndTheTiesAreDrawnAndADragDentsOneThatComesBackWhenReleased) {
  auto s = tied_spheres();
  s->start();
  ASSERT_TRUE(simulate_for(*s, 0.2));
  ASSERT_EQ(s->snapshot().bodies.size(), 2u);
  const int64_t ties = s->snapshot().tie_count.total;
  ASSERT_GT(ties, 10);
  s->frame();
  const auto& drawn = render::last_frame();
  ASSERT_EQ(drawn.size(), 2u);
  size_t beads = 0;
  for (const render::DrawnModel& d : drawn) beads += d.overlays.markers.size();
  EXPECT_EQ(static_cast<int64_t>(beads), ties) << "every active tie is drawn";

  // A drag on body a (the camera is fitted on it: the window's centre is on it).
  drag_from(*s, render::window_size().cast<double>() / 2.0, Eigen::Vector2d(0, -24.0));
  EXPECT_THAT(s->last_press(), HasSubstr("drag a node"));
  ASSERT_TRUE(simulate_for(*s, 1.0));
  EXPECT_GT(moved(s->snapshot().bodies[0]), 1.0) << "the drag did not move body a";
  bool arrow = false;
  for (const render::DrawnModel& d : render::last_frame()) arrow |= !d.overlays.arrows.empty();
  EXPECT_TRUE(arrow) << "the drag's force is not drawn";
  render::inject(InputEvent::release(MouseButton::kLeft));
  s->frame();
  ASSERT_TRUE(simulate_until_rest(*s, 4.0, [&] { return moved(s->snapshot().bodies[0]) < 0.3; }));
  EXPECT_LT(moved(s->snapshot().bodies[0]), 0.3) << "released, body a did not come back";
  s->finish();
  const nlohmann::json r = s->report();
  EXPECT_EQ(r["drags"], 1);
  EXPECT_EQ(r["bodies"].size(), 2u);
  EXPECT_GT(r["bodies"][0]["max_displacement_mm"].get<double>(), 1.0);
  EXPECT_EQ(r["unstable_events"], 0);
}

TEST_F(WorldViewTest, TheGrasperHoldsTheBodyPressedRetractsItWithTheDragAndLetsGo) {
  // G, then a press on body a and a drag: its jaws close on the skin there (the world loop's
  // grasper), the held skin follows them, release opens them and the body comes back.
  auto s = tied_spheres();
  s->start();
  ASSERT_TRUE(simulate_for(*s, 0.1));
  render::inject(InputEvent::key_down("g"));
  render::inject(InputEvent::key_up("g"));
  s->frame();
  drag_from(*s, render::window_size().cast<double>() / 2.0, Eigen::Vector2d(0, -24.0));
  EXPECT_THAT(s->last_press(), HasSubstr("grasp a node"));
  ASSERT_TRUE(frames_until(
      *s, [&] { return s->snapshot().grasped_body == "a"; }, 20.0))
      << "the jaws never closed: " << s->last_press();
  ASSERT_TRUE(simulate_for(*s, 1.0));
  EXPECT_GT(s->snapshot().grasped_nodes, 0);
  EXPECT_GT(moved(s->snapshot().bodies[0]), 2.0) << "the held skin did not follow the jaws";
  EXPECT_GT(s->snapshot().hands_reaction_mn.norm(), 10.0) << "the grasper feels no pull";
  render::inject(InputEvent::release(MouseButton::kLeft));
  s->frame();
  ASSERT_TRUE(frames_until(
      *s, [&] { return s->snapshot().grasped_body.empty(); }, 20.0));
  ASSERT_TRUE(simulate_until_rest(*s, 4.0, [&] { return moved(s->snapshot().bodies[0]) < 0.3; }));
  EXPECT_EQ(s->snapshot().unstable, sim::Instability::kNone);
  EXPECT_LT(moved(s->snapshot().bodies[0]), 0.3) << "let go, body a did not come back";
  s->finish();
  EXPECT_EQ(s->report()["grasps"], 1);
}

TEST_F(WorldViewTest, ADissectionDragAcrossTheMeetingDividesTheTiesItPassesAndResetPutsThemBack) {
  auto s = tied_spheres();
  s->start();
  ASSERT_TRUE(simulate_for(*s, 0.1));
  const Eigen::Vector3d meet =
      world::test_world::sphere_centre() + Eigen::Vector3d(20.25, 0.0, 0.0);
  stroke_down(*s, "x", pixel_of(meet), 60.0);
  EXPECT_THAT(s->last_press(), HasSubstr("dissection"));
  ASSERT_TRUE(frames_until(
      *s, [&] { return s->snapshot().tie_count.divided > 0; }, 10.0))
      << "the stroke divided nothing";
  EXPECT_EQ(s->snapshot().ties_divided_by_strokes, s->snapshot().tie_count.divided);
  EXPECT_EQ(s->report()["strokes"], 1);
  render::inject(InputEvent::key_down("r"));
  render::inject(InputEvent::key_up("r"));
  s->frame();
  ASSERT_TRUE(frames_until(
      *s, [&] { return s->snapshot().tie_count.divided == 0; }, 10.0))
      << "a reset did not put the ties back";
  s->finish();
}

TEST_F(WorldViewTest, AScalpelDragCutsTheBodyItCrossesWhichIsDrawnAndDraggedOnItsNewNodes) {
  auto s = tied_spheres();
  s->start();
  ASSERT_TRUE(simulate_for(*s, 0.1));
  const int32_t nodes = s->snapshot().bodies[0].model->node_count();
  // K, then a drag down across body a's middle.
  stroke_down(*s, "k", pixel_of(world::test_world::sphere_centre()), 150.0);
  EXPECT_THAT(s->last_press(), HasSubstr("scalpel on a"));
  ASSERT_TRUE(frames_until(
      *s, [&] { return s->snapshot().bodies[0].topology == 1; }, 20.0))
      << "the scalpel cut nothing: " << s->snapshot().cut_message;
  const world::BodyView& a = s->snapshot().bodies[0];
  EXPECT_GT(a.model->node_count(), nodes) << s->snapshot().tets_cut << " tetrahedra divided";
  EXPECT_EQ(s->snapshot().bodies[1].topology, 0u) << "the blade stayed inside body a";
  EXPECT_GE(s->snapshot().cuts, 1);
  s->frame();
  bool drawn_cut = false;
  for (const render::DrawnModel& d : render::last_frame())
    drawn_cut |= d.name == "a" && d.nodes == a.model->node_count();
  EXPECT_TRUE(drawn_cut) << "body a is not drawn with its cut model";

  // The cut body is dragged on its new numbering, and comes back.
  render::inject(InputEvent::key_down("k"));
  render::inject(InputEvent::key_up("k"));
  drag_from(*s, pixel_of(world::test_world::sphere_centre() + Eigen::Vector3d(0.0, 12.0, 0.0)),
            Eigen::Vector2d(-24.0, 0));
  EXPECT_THAT(s->last_press(), HasSubstr("drag a node"));
  ASSERT_TRUE(simulate_for(*s, 1.0));
  EXPECT_GT(moved(s->snapshot().bodies[0]), 1.0) << "the drag did not move the cut body";
  EXPECT_EQ(s->status(), "") << "the drag's force was refused";
  render::inject(InputEvent::release(MouseButton::kLeft));
  s->frame();
  ASSERT_TRUE(simulate_until_rest(*s, 3.0, [&] { return moved(s->snapshot().bodies[0]) < 0.5; }));
  EXPECT_EQ(s->snapshot().unstable, sim::Instability::kNone);
  EXPECT_LT(moved(s->snapshot().bodies[0]), 0.5) << "released, the cut body did not come back";

  // R puts the uncut body back, drawn whole.
  render::inject(InputEvent::key_down("r"));
  render::inject(InputEvent::key_up("r"));
  s->frame();
  ASSERT_TRUE(frames_until(
      *s, [&] { return s->snapshot().bodies[0].topology == 2; }, 10.0));
  EXPECT_EQ(s->snapshot().bodies[0].model->node_count(), nodes);
  s->frame();
  s->frame();
  for (const render::DrawnModel& d : render::last_frame())
    if (d.name == "a") EXPECT_EQ(d.nodes, nodes);
  s->finish();
  EXPECT_EQ(s->report()["cuts"]["strokes"], 1);
}

// A force pinned on a body (Shift at the drag's release) goes on through a cut of it: the loop
// carries it to its node's first copy and the view follows it there (it is not sent again on the
// old numbering, which the loop would refuse); C then lets it go and the cut body comes back.
TEST_F(WorldViewTest, APinnedForceGoesOnThroughACutOfItsBodyAndCLetsItGo) {
  auto s = tied_spheres();
  s->start();
  ASSERT_TRUE(simulate_for(*s, 0.1));
  drag_from(*s, pixel_of(world::test_world::sphere_centre() + Eigen::Vector3d(0.0, 12.0, 0.0)),
            Eigen::Vector2d(-24.0, 0));
  ASSERT_THAT(s->last_press(), HasSubstr("drag a node"));
  render::inject(InputEvent::key_down("shift"));
  s->frame();
  render::inject(InputEvent::release(MouseButton::kLeft));
  s->frame();
  render::inject(InputEvent::key_up("shift"));
  s->frame();
  ASSERT_TRUE(simulate_for(*s, 1.0));
  ASSERT_EQ(s->snapshot().bodies[0].force_nodes.size(), 1u) << "Shift did not pin the drag";
  const double pinned_moved = moved(s->snapshot().bodies[0]);
  ASSERT_GT(pinned_moved, 1.0) << "the pinned force did not move body a";

  stroke_down(*s, "k", pixel_of(world::test_world::sphere_centre()), 150.0);
  ASSERT_TRUE(frames_until(
      *s, [&] { return s->snapshot().bodies[0].topology == 1; }, 20.0))
      << "the scalpel cut nothing: " << s->snapshot().cut_message;
  ASSERT_TRUE(simulate_for(*s, 1.0));
  EXPECT_EQ(s->status(), "") << "the pinned force was sent on the old numbering";
  ASSERT_EQ(s->snapshot().bodies[0].force_nodes.size(), 1u) << "the cut let the pin go";
  EXPECT_GT(moved(s->snapshot().bodies[0]), 0.5 * pinned_moved) << "the pin stopped pulling";
  EXPECT_EQ(s->snapshot().unstable, sim::Instability::kNone);
  s->frame();
  bool arrow = false;
  for (const render::DrawnModel& d : render::last_frame())
    arrow |= d.name == "a" && !d.overlays.arrows.empty();
  EXPECT_TRUE(arrow) << "the view forgot the pin the loop still pulls with";

  render::inject(InputEvent::key_down("c"));
  render::inject(InputEvent::key_up("c"));
  s->frame();
  ASSERT_TRUE(simulate_until_rest(*s, 3.0, [&] { return moved(s->snapshot().bodies[0]) < 0.5; }));
  EXPECT_TRUE(s->snapshot().bodies[0].force_nodes.empty());
  EXPECT_LT(moved(s->snapshot().bodies[0]), 0.5) << "C did not let the cut body go back";
  s->finish();
}

TEST_F(WorldViewTest, UUndoesTheLastCutAndTheBodyIsDrawnWholeAgain) {
  auto s = tied_spheres();
  s->start();
  ASSERT_TRUE(simulate_for(*s, 0.1));
  const int32_t nodes = s->snapshot().bodies[0].model->node_count();
  stroke_down(*s, "k", pixel_of(world::test_world::sphere_centre()), 150.0);
  ASSERT_TRUE(frames_until(
      *s, [&] { return s->snapshot().bodies[0].topology == 1; }, 20.0))
      << "the scalpel cut nothing: " << s->snapshot().cut_message;
  EXPECT_EQ(s->snapshot().undoable, 1);
  render::inject(InputEvent::key_down("u"));
  render::inject(InputEvent::key_up("u"));
  s->frame();
  ASSERT_TRUE(frames_until(
      *s, [&] { return s->snapshot().bodies[0].topology == 2; }, 10.0))
      << "U did not take the cut back: " << s->snapshot().cut_message;
  EXPECT_EQ(s->snapshot().bodies[0].model->node_count(), nodes);
  EXPECT_EQ(s->snapshot().cuts, 0);
  EXPECT_EQ(s->snapshot().undoable, 0);
  s->frame();
  s->frame();
  for (const render::DrawnModel& d : render::last_frame())
    if (d.name == "a") EXPECT_EQ(d.nodes, nodes) << "drawn whole again";
  // Nothing more to undo: said, nothing changed.
  render::inject(InputEvent::key_down("u"));
  render::inject(InputEvent::key_up("u"));
  ASSERT_TRUE(frames_until(
      *s, [&] { return !s->snapshot().cut_message.empty(); }, 10.0));
  EXPECT_THAT(s->snapshot().cut_message, HasSubstr("no cut to undo"));
  EXPECT_EQ(s->snapshot().bodies[0].topology, 2u);
  s->finish();
  EXPECT_EQ(s->report()["cuts"]["bodies_cut"], 0);
}

}  // namespace
}  // namespace lamina::cli
