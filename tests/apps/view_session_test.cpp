// `lamina view`'s session (apps/lamina/view/view_session.h) on the viewer engine's mock backend: no
// display, no OpenGL, input injected through the same queue a window feeds. A drag on the organ
// dents it and release lets it return to rest; Shift at release pins the force; a press off the
// organ orbits the camera and pushes nothing; a press on a panel is the panel's; a scripted
// rebuild swaps the model under the running simulation. The simulation runs as fast as it can
// (rate 0, the paper's 10 ms steps), and the tests wait on simulated time, not on the clock: the
// paper's model (unit masses, K = 3 N/m) dents slowly, a few mm in the first seconds. The tests
// that pull hard and wait for the return run the physical tissue (tissue_options()).
#include "view_session.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "lamina/geometry/make_phantom.h"
#include "lamina/model/build_model.h"
#include "lamina/model/embed_surface.h"
#include "lamina/render/viewer.h"
#include "support/session_frames.h"
#include "support/sphere_model.h"
#include "support/temp_dir.h"
#include "support/volumes.h"

namespace lamina::cli {
namespace {

using render::InputEvent;
using render::MouseButton;
using ::testing::HasSubstr;

// The posterior cap held (as a scene's boundary would be).
std::vector<int32_t> posterior_cap(const Model& m) {
  std::vector<int32_t> back;
  const double y_max = m.X.col(1).maxCoeff();
  for (int32_t i = 0; i < m.node_count(); ++i)
    if (m.X(i, 1) > y_max - 8.0) back.push_back(i);
  return back;
}

ViewModel sphere_view_model() {
  ViewModel vm;
  vm.model = test::sphere_model();
  vm.fixed = posterior_cap(vm.model);
  vm.source = "a sphere";
  return vm;
}

// What the tests' rebuild callback builds: a sphere mask meshed with the asked layers and skin.
ViewModel rebuilt_sphere(int32_t layers, int32_t skin_vertices, const ProgressFn& progress) {
  LabelVolume v = test::empty_volume(50, 1.0);
  test::paint_sphere(v, v.frame.to_physical(24.5, 24.5, 24.5), 20.0, 1);
  ViewModel vm;
  vm.model =
      model::build_model(v, {.layers = layers, .skin_vertices = skin_vertices}, progress).model;
  vm.fixed = posterior_cap(vm.model);
  vm.source = "a rebuilt sphere";
  return vm;
}

ViewOptions fast_options() {
  ViewOptions o;
  o.rate_hz = 0.0;         // as fast as possible, at the solver's 10 ms step
  o.gain_n_per_mm = 0.05;  // the scene files' gain: a 120-pixel drag on this small organ is ~8 mm
  return o;
}

// The viewer's own default, the physical tissue (E = 6 kPa, the model's lumped masses, implicit
// Euler), for the tests that pull hard and wait for the organ to come back. The paper's springs
// alone (fast_options) can fold under a pull past about 26 mm on this 20 mm sphere and stay folded,
// and how far the same 120-pixel drag pulls depends on the frames' timing (each new force is
// routed on the shape of the moment): spaced frames made the pull 19-46 mm, and 11 of 17 pulls of
// 26-46 mm never came back (a CI run of 2026-12-04; docs/testing.md). On the tissue it
// pulls 8.9-9.9 mm whatever the timing, and returns.
ViewOptions tissue_options() {
  ViewOptions o = fast_options();
  o.material.young_modulus_kpa = 6.0;
  o.material.stiffness_n_per_m = 0.0;  // the tetrahedra's identified constants
  o.material.node_mass_kg = 0.0;       // the model's lumped masses
  o.solver.integrator = sim::Integrator::kImplicitEuler;
  return o;
}

double largest_displacement(const ViewSession& s) {
  const Eigen::MatrixX3d& x = s.snapshot().x;
  if (x.rows() != s.model().node_count()) return 0.0;
  return (x - s.model().X).rowwise().norm().maxCoeff();
}

using test::frames_until;
using test::simulate_for;

class ViewSessionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    render::ViewerOptions o;
    o.backend = render::Backend::kMock;
    render::init(o);
  }
  void TearDown() override { render::shutdown(); }

  // A drag on the window's centre (the organ), `dy` pixels up over a few frames, held for
  // `hold_s` of simulated time.
  void drag_from_centre(ViewSession& s, double dy, double hold_s) {
    const Eigen::Vector2d c = render::window_size().cast<double>() / 2.0;
    render::inject(InputEvent::move_to(c));
    s.frame();
    render::inject(InputEvent::press(MouseButton::kLeft));
    s.frame();
    for (int i = 1; i <= 5; ++i) {
      render::inject(InputEvent::move_to(c - Eigen::Vector2d(0, dy * i / 5)));
      s.frame();
    }
    ASSERT_TRUE(simulate_for(s, hold_s));
  }
  // Shift held while the left button goes up (each in its own frame, as a hand does it).
  static void shift_release(ViewSession& s) {
    render::inject(InputEvent::key_down("shift"));
    s.frame();
    render::inject(InputEvent::release(MouseButton::kLeft));
    s.frame();
    render::inject(InputEvent::key_up("shift"));
    s.frame();
  }
};

TEST_F(ViewSessionTest, ADragOnTheOrganDentsItAndReleaseLetsItReturnToRest) {
  ViewSession s(tissue_options(), sphere_view_model());
  s.start();
  ASSERT_TRUE(simulate_for(s, 0.2));
  EXPECT_LT(largest_displacement(s), 1e-6) << "the organ moved with nobody touching it";

  drag_from_centre(s, 120.0, 5.0);
  EXPECT_THAT(s.last_press(), HasSubstr("drag node"));
  const double dented = largest_displacement(s);
  EXPECT_GT(dented, 2.0) << "the drag did not move the skin";
  // While dragging, the engine shows the simulation's state and the drag's arrow.
  s.frame();
  ASSERT_EQ(render::last_frame().size(), 1u);
  EXPECT_EQ(render::last_frame()[0].overlays.arrows.size(), 1u);
  EXPECT_EQ(render::positions(ViewSession::kModelName).rows(), s.model().node_count());
  EXPECT_GT((render::positions(ViewSession::kModelName) - s.model().X).rowwise().norm().maxCoeff(),
            0.5 * dented)
      << "the engine was not given the dented positions";

  render::inject(InputEvent::release(MouseButton::kLeft));
  s.frame();
  EXPECT_TRUE(render::last_frame()[0].overlays.arrows.empty()) << "the force outlived the drag";
  ASSERT_TRUE(frames_until(s, [&] { return largest_displacement(s) < 0.05 * dented; }))
      << "the organ did not return to rest: " << largest_displacement(s) << " mm";
  s.finish();
  const nlohmann::json r = s.report();
  EXPECT_EQ(r["drags"], 1);
  EXPECT_EQ(r["pinned_forces"], 0);
  EXPECT_GT(r["drag_peak_displacement_mm"].get<double>(), 2.0);
  EXPECT_EQ(r["recoveries"], 0);
}

// K, then a drag across the organ: the release cuts along the traced path (the blade along the
// view, the panel's depth under it); the session shows the cut model from then on, with as many
// positions as it has nodes, and the cut organ stays at rest.
TEST_F(ViewSessionTest, TheScalpelCutsAlongTheDragTheCutModelIsShownAndUUndoesIt) {
  ViewSession s(fast_options(), sphere_view_model());
  s.start();
  const int32_t before = s.model().node_count();
  render::inject(InputEvent::key_down("k"));
  render::inject(InputEvent::key_up("k"));
  s.frame();
  const Eigen::Vector2d c = render::window_size().cast<double>() / 2.0;
  render::inject(InputEvent::move_to(c - Eigen::Vector2d(150, 0)));
  s.frame();
  render::inject(InputEvent::press(MouseButton::kLeft));
  s.frame();
  EXPECT_THAT(s.last_press(), HasSubstr("scalpel"));
  for (int i = 1; i <= 20; ++i) {
    render::inject(InputEvent::move_to(c + Eigen::Vector2d(-150.0 + 15.0 * i, 0)));
    s.frame();
  }
  render::inject(InputEvent::release(MouseButton::kLeft));
  s.frame();
  ASSERT_TRUE(frames_until(
      s, [&] { return s.report()["cuts"].get<int>() >= 1; }, 30.0))
      << "no cut";
  EXPECT_GT(s.model().node_count(), before);
  EXPECT_EQ(s.report()["nodes"].get<int>(), s.model().node_count());
  ASSERT_TRUE(simulate_for(s, 0.5));
  s.frame();
  EXPECT_EQ(render::positions(ViewSession::kModelName).rows(), s.model().node_count());
  EXPECT_LT(largest_displacement(s), 0.5) << "the cut organ did not stay at rest";
  EXPECT_EQ(s.report()["recoveries"], 0);

  // U takes the cut back: the model the session began with is shown again, at rest.
  render::inject(InputEvent::key_down("u"));
  render::inject(InputEvent::key_up("u"));
  s.frame();
  ASSERT_TRUE(frames_until(
      s, [&] { return s.report()["cuts"].get<int>() == 0; }, 30.0))
      << "U did not undo the cut";
  EXPECT_EQ(s.model().node_count(), before);
  ASSERT_TRUE(simulate_for(s, 0.5));
  s.frame();
  EXPECT_EQ(render::positions(ViewSession::kModelName).rows(), before);
  EXPECT_LT(largest_displacement(s), 0.5) << "the organ did not stay at rest after the undo";
}

TEST_F(ViewSessionTest, ShiftAtReleasePinsTheForceUntilC) {
  ViewSession s(tissue_options(), sphere_view_model());
  s.start();
  drag_from_centre(s, 120.0, 5.0);
  shift_release(s);
  ASSERT_TRUE(simulate_for(s, 3.0));
  EXPECT_EQ(s.report()["pinned_forces"], 1);
  const double pinned = largest_displacement(s);
  EXPECT_GT(pinned, 2.0) << "the pinned force stopped acting";
  EXPECT_EQ(render::last_frame()[0].overlays.arrows.size(), 1u) << "the pinned force's arrow";

  render::inject(InputEvent::key_down("c"));
  render::inject(InputEvent::key_up("c"));
  s.frame();
  EXPECT_EQ(s.report()["pinned_forces"], 0);
  ASSERT_TRUE(frames_until(s, [&] { return largest_displacement(s) < 0.05 * pinned; }))
      << "C did not release the pinned force";
}

TEST_F(ViewSessionTest, TheGrasperHoldsTheSkinItPressesFollowsTheDragAndLetsGo) {
  // G, then a press on the organ: the jaws close on the picked node and the skin around it; the
  // drag moves them (the held skin follows, marked), release opens them and the organ returns;
  // Shift+release keeps holding until C.
  ViewSession s(fast_options(), sphere_view_model());
  s.start();
  render::inject(InputEvent::key_down("g"));
  render::inject(InputEvent::key_up("g"));
  s.frame();
  drag_from_centre(s, 120.0, 1.0);
  EXPECT_THAT(s.last_press(), HasSubstr("grasp node"));
  // The loop closes the jaws on its next step, which a loaded machine can publish after the
  // drag's hold has run on an older snapshot's clock (a CI run of 2026-11-29 checked before
  // it): wait for the grasp, then hold.
  ASSERT_TRUE(frames_until(s, [&] { return !s.snapshot().grasped_nodes.empty(); }))
      << "the jaws never closed";
  ASSERT_TRUE(simulate_for(s, 1.0));
  const double pulled = largest_displacement(s);
  EXPECT_GT(pulled, 2.0) << "the held skin did not follow the jaws";
  s.frame();
  EXPECT_GE(render::last_frame()[0].overlays.markers.size(), s.snapshot().grasped_nodes.size())
      << "the held nodes are marked";
  shift_release(s);
  ASSERT_TRUE(simulate_for(s, 1.0));
  EXPECT_FALSE(s.snapshot().grasped_nodes.empty()) << "Shift+release keeps holding";
  EXPECT_GT(largest_displacement(s), 0.9 * pulled);
  render::inject(InputEvent::key_down("c"));
  render::inject(InputEvent::key_up("c"));
  s.frame();
  ASSERT_TRUE(frames_until(s, [&] { return s.snapshot().grasped_nodes.empty(); }))
      << "C did not open the jaws";
  // The paper's constants (unit masses, gamma = 3 kg/s per node, K = 3 N/m) make the return
  // overdamped: the whole sphere creeps back with a half-life of about 80 s of simulated time
  // (8.7 mm pulled: 2.9 mm 30 s after C, 0.8 mm after 160 s; measured 2026-12-02). The test
  // waits on simulated time, which a sanitizer build takes 20x the wall clock to step.
  ASSERT_TRUE(simulate_for(s, 30.0));
  EXPECT_LT(largest_displacement(s), 0.5 * pulled) << "C did not let the organ return";
}

TEST_F(ViewSessionTest, AScenesGrasperClosesAtStartPullsHoldsAndClosesAgainAfterAReset) {
  // A scene's grasper on the front of the sphere: from the start its jaws hold the skin there
  // and pull it 6 mm forward over 1 s, then hold; R puts the organ at rest and the grasper
  // closes again and pulls again; C lets go and the organ returns.
  ViewModel vm = sphere_view_model();
  Eigen::Index front = 0;
  vm.model.X.topRows(vm.model.layers[0].node_count).col(1).minCoeff(&front);
  interact::Tool g;
  g.grasp = true;
  g.by_point = true;
  g.point_mm = vm.model.X.row(front).transpose();
  g.radius_mm = 4.0;
  g.pull_mm = Eigen::Vector3d(0.0, -6.0, 0.0);
  g.pull_s = 1.0;
  vm.grasper = g;
  const Eigen::Vector3d rest = vm.model.X.row(front).transpose();
  ViewSession s(fast_options(), std::move(vm));
  s.start();
  const auto front_moved = [&] {
    const Eigen::MatrixX3d& x = s.snapshot().x;
    return x.rows() > front ? (x.row(front).transpose() - rest).y() : 0.0;
  };
  ASSERT_TRUE(frames_until(s, [&] { return !s.snapshot().grasped_nodes.empty(); }));
  // Under load the first close can be retried and land late, as the close after R below (two
  // CI runs of 2026-11-28 saw -4.62 mm 2 s after the jaws first held): wait for the pull, then
  // check it holds.
  ASSERT_TRUE(frames_until(s, [&] { return std::abs(front_moved() + 6.0) < 0.5; }))
      << "pulled by pull_mm: " << front_moved() << " mm";
  ASSERT_TRUE(simulate_for(s, 1.0));
  EXPECT_NEAR(front_moved(), -6.0, 0.5) << "pulled by pull_mm and held";
  EXPECT_FALSE(s.snapshot().grasped_nodes.empty());
  render::inject(InputEvent::key_down("r"));
  render::inject(InputEvent::key_up("r"));
  s.frame();
  // The clock starts again from 0 (the loop outruns the frames: only its restart is seen).
  const double before = s.snapshot().time_s;
  ASSERT_TRUE(frames_until(s, [&] { return s.snapshot().time_s < before; }));
  // Under load the close after R can land up to about a second of simulated time late (the
  // loop may still show the pulled shape, and the close is retried): wait for the pull, then
  // check it holds.
  ASSERT_TRUE(frames_until(
      s,
      [&] { return !s.snapshot().grasped_nodes.empty() && std::abs(front_moved() + 6.0) < 0.5; }))
      << "closed again at the start after R: " << front_moved() << " mm";
  ASSERT_TRUE(simulate_for(s, 1.0));
  EXPECT_NEAR(front_moved(), -6.0, 0.5) << "held after the pull";
  EXPECT_FALSE(s.snapshot().grasped_nodes.empty());
  render::inject(InputEvent::key_down("c"));
  render::inject(InputEvent::key_up("c"));
  s.frame();
  ASSERT_TRUE(frames_until(
      s, [&] { return s.snapshot().grasped_nodes.empty() && std::abs(front_moved()) < 0.3; }))
      << "C did not let go: " << front_moved() << " mm";
}

TEST_F(ViewSessionTest, APressOffTheOrganOrbitsInsteadOfPushing) {
  ViewSession s(fast_options(), sphere_view_model());
  s.start();
  s.frame();
  // The bottom right corner: no panel there, and the organ is framed with a margin.
  const Eigen::Vector2i size = render::window_size();
  const Eigen::Vector2d corner(0.97 * size.x(), 0.97 * size.y());
  const double azimuth = render::camera().azimuth_deg;
  render::inject(InputEvent::move_to(corner));
  s.frame();
  render::inject(InputEvent::press(MouseButton::kLeft));
  s.frame();
  EXPECT_THAT(s.last_press(), HasSubstr("missed the organ: orbit"));
  render::inject(InputEvent::move_to(corner - Eigen::Vector2d(100, 0)));
  s.frame();
  render::inject(InputEvent::release(MouseButton::kLeft));
  s.frame();
  EXPECT_NEAR(render::camera().azimuth_deg, azimuth + 30.0, 1e-9) << "0.3 degrees a pixel";
  ASSERT_TRUE(simulate_for(s, 0.5));
  EXPECT_EQ(s.report()["drags"], 0);
  EXPECT_LT(largest_displacement(s), 1e-6) << "a press off the organ pushed it";
}

TEST_F(ViewSessionTest, APressOnAPanelIsThePanelsAndSaysSo) {
  ViewSession s(fast_options(), sphere_view_model());
  s.start();
  s.frame();
  s.frame();  // the panels exist from the first frame; Dear ImGui hovers them from the next
  render::inject(InputEvent::move_to({100, 60}));  // inside the "Lamina" panel
  s.frame();
  render::inject(InputEvent::press(MouseButton::kLeft));
  s.frame();
  render::inject(InputEvent::release(MouseButton::kLeft));
  s.frame();
  EXPECT_THAT(s.last_press(), HasSubstr("a panel has the mouse"));
  EXPECT_EQ(s.report()["drags"], 0);
}

TEST_F(ViewSessionTest, AScriptedRebuildSwapsTheModelUnderTheRunningSimulation) {
  test::TempDir dir;
  std::ofstream(dir.file("rebuild.json"))
      << R"({"events": [{"at": 0.5, "rebuild": {"layers": 3, "skin_vertices": 400}},
                        {"at": 0.0, "screenshot": ")"
      << dir.file("before.png") << R"("}]})";
  ViewOptions o = fast_options();
  o.script = dir.file("rebuild.json");
  o.report = dir.file("report.json");
  int rebuilds_asked = 0;
  o.rebuild = [&](int32_t layers, int32_t skin_vertices, const ProgressFn& progress) {
    ++rebuilds_asked;
    return rebuilt_sphere(layers, skin_vertices, progress);
  };
  ViewSession s(o, sphere_view_model());
  EXPECT_FALSE(s.script_drives_mouse());
  const int32_t before = s.model().node_count();
  s.start();
  // A drag on the first model, before the script's rebuild at 0.5 s.
  drag_from_centre(s, 120.0, 0.5);
  render::inject(InputEvent::release(MouseButton::kLeft));
  s.frame();
  EXPECT_EQ(s.report()["rebuilds"], 0) << "too slow: the rebuild came before the first drag";
  EXPECT_GE(s.report()["drag_node"].get<int>(), 0);
  ASSERT_TRUE(frames_until(
      s, [&] { return s.report()["rebuilds"] == 1; }, 120.0))
      << "the rebuild did not finish";
  // The first drag's nodes were the old model's: its record ended with it.
  EXPECT_EQ(s.report()["drag_node"], -1);
  EXPECT_FALSE(s.report().contains("drag_peak_distance_from_drag_mm"));
  EXPECT_EQ(rebuilds_asked, 1);
  EXPECT_EQ(s.model().layer_count(), 3);
  EXPECT_NE(s.model().node_count(), before);
  // The engine shows the new model, and the simulation runs on it.
  EXPECT_EQ(render::positions(ViewSession::kModelName).rows(), s.model().node_count());
  ASSERT_TRUE(frames_until(s, [&] {
    return s.snapshot().x.rows() == s.model().node_count() && s.snapshot().steps > 10;
  }));
  drag_from_centre(s, 120.0, 5.0);
  EXPECT_THAT(s.last_press(), HasSubstr("drag node"));
  EXPECT_GT(largest_displacement(s), 1.0) << "dragging the rebuilt model failed";
  render::inject(InputEvent::release(MouseButton::kLeft));
  s.frame();
  s.finish();
  std::ifstream report(dir.file("report.json"));
  ASSERT_TRUE(report) << "no report written";
  const nlohmann::json r = nlohmann::json::parse(report);
  EXPECT_EQ(r["rebuilds"], 1);
  EXPECT_EQ(r["layers"], 3);
  EXPECT_EQ(r["drags"], 2);
  ASSERT_EQ(r["screenshots"].size(), 1u);
  EXPECT_TRUE(std::filesystem::exists(dir.file("before.png")));
}

// A script's "wait": "rebuild" holds its clock until the new model is in use, however long the
// build takes: here the build is held back by the test for a second of frames.
TEST_F(ViewSessionTest, AScriptWaitsForItsRebuildHoweverLongItTakes) {
  test::TempDir dir;
  std::ofstream(dir.file("wait.json"))
      << R"({"events": [{"at": 0.0, "rebuild": {"layers": 3, "skin_vertices": 400}},
                        {"at": 0.0, "wait": "rebuild"},
                        {"at": 0.1, "screenshot": ")"
      << dir.file("after.png") << R"("}]})";
  ViewOptions o = fast_options();
  o.script = dir.file("wait.json");
  std::atomic<bool> build_may_finish{false};
  o.rebuild = [&](int32_t layers, int32_t skin_vertices, const ProgressFn& progress) {
    while (!build_may_finish) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    return rebuilt_sphere(layers, skin_vertices, progress);
  };
  ViewSession s(o, sphere_view_model());
  // Declared after the session, so destroyed before it: a failed check below still lets the
  // build finish before the session joins its thread.
  struct Release {
    std::atomic<bool>& flag;
    ~Release() { flag = true; }
  } release{build_may_finish};
  s.start();
  frames_until(
      s, [] { return false; }, 1.0);
  EXPECT_FALSE(std::filesystem::exists(dir.file("after.png")))
      << "the script went on before the model it waits for was in use";
  EXPECT_EQ(s.report()["rebuilds"], 0);
  build_may_finish = true;
  ASSERT_TRUE(frames_until(
      s, [&] { return std::filesystem::exists(dir.file("after.png")); }, 120.0))
      << "the script did not go on after the rebuild";
  EXPECT_EQ(s.report()["rebuilds"], 1);
  EXPECT_EQ(s.model().layer_count(), 3);
  s.finish();
}

// "wait": "settled" played in the same frame as the release before it still waits for the 3
// simulated seconds after that release: the release reaches the gestures only when the frame
// runs, after the script has been played.
TEST_F(ViewSessionTest, AScriptWaitsForTheOrganToSettleAfterItsRelease) {
  test::TempDir dir;
  std::ofstream(dir.file("settle.json")) << R"({"events": [{"at": 0.0, "mouse": [0.5, 0.5]},
                        {"at": 0.05, "press": "left"},
                        {"at": 0.1, "mouse": [0.5, 0.4], "over": 0.2},
                        {"at": 0.5, "release": "left"},
                        {"at": 0.5, "wait": "settled"},
                        {"at": 0.5, "screenshot": ")"
                                         << dir.file("settled.png") << R"("}]})";
  ViewOptions o = fast_options();
  o.rate_hz = 1000.0;  // real time: 3 simulated seconds take 3 s here, not one frame
  o.script = dir.file("settle.json");
  ViewSession s(o, sphere_view_model());
  s.start();
  ASSERT_TRUE(frames_until(s, [&] { return std::filesystem::exists(dir.file("settled.png")); }))
      << "the script never went on";
  EXPECT_EQ(s.report()["drags"], 1) << s.last_press();
  EXPECT_GE(s.report()["max_displacement_3s_after_release_mm"].get<double>(), 0.0)
      << "the script went on before the 3 simulated seconds after the release";
  s.finish();
}

}  // namespace
}  // namespace lamina::cli

namespace lamina::cli {
namespace {

// The phantom with its anatomy, small: a display skin and two structures inside.
ViewModel anatomy_view_model() {
  model::BuildOptions o;
  o.display_triangles = 5000;
  o.structure_triangles = 3000;
  o.embed = {{.name = "vessels", .label = 2}, {.name = "tumour", .label = 3}};
  ViewModel vm;
  vm.model =
      model::build_model(geometry::make_phantom({.spacing_mm = {3, 3, 3}, .anatomy = true}), o)
          .model;
  vm.fixed = posterior_cap(vm.model);
  vm.source = "the phantom's anatomy";
  return vm;
}

TEST_F(ViewSessionTest, TheDisplaySkinAndStructuresFollowTheDragAndTheDisplayKeyToggles) {
  ViewSession s(fast_options(), anatomy_view_model());
  ASSERT_EQ(s.model().embedded.size(), 3u);
  s.start();
  s.frame();
  // Shown as default_style says: the display skin, both structures, a translucent skin.
  const std::string name = ViewSession::kModelName;
  EXPECT_TRUE(render::style(name).display_skin);
  ASSERT_EQ(render::style(name).embedded.size(), 3u);
  EXPECT_TRUE(render::style(name).embedded[1].visible && render::style(name).embedded[2].visible);
  EXPECT_LT(render::style(name).skin_alpha, 1.0f);

  drag_from_centre(s, 120.0, 1.0);
  EXPECT_THAT(s.last_press(), HasSubstr("drag node"));
  // The drag still acting, frame after frame: each frame draws the structures where the
  // organ's positions put them, and (the deep vessels lag the skin, more so on a loaded machine)
  // within 5 s each has moved with the organ.
  std::vector<double> moved(3, 0.0);
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < 3 || *std::min_element(moved.begin(), moved.end()) <= 0.01; ++k) {
    if (std::chrono::steady_clock::now() - t0 > std::chrono::seconds(5)) break;
    s.frame();
    const Eigen::MatrixX3d& x = render::positions(name);
    ASSERT_GT((x - s.model().X).rowwise().norm().maxCoeff(), 0.5) << "the drag moved nothing";
    const std::vector<Eigen::MatrixX3d>& drawn = render::embedded_positions(name);
    ASSERT_EQ(drawn.size(), 3u);
    for (size_t i = 0; i < drawn.size(); ++i) {
      Eigen::MatrixX3d expected;
      model::embedded_positions(s.model().embedded[i], x, expected);
      EXPECT_TRUE(drawn[i] == expected) << s.model().embedded[i].name << " after frame " << k;
      moved[i] = (drawn[i] - s.model().embedded[i].V).rowwise().norm().maxCoeff();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  for (size_t i = 0; i < moved.size(); ++i)
    EXPECT_GT(moved[i], 0.01) << s.model().embedded[i].name << " did not move with the organ";

  render::inject(InputEvent::key_down("d"));
  s.frame();
  EXPECT_FALSE(render::style(name).display_skin) << "D did not switch to the simulation's skin";
  render::inject(InputEvent::key_up("d"));
  render::inject(InputEvent::key_down("d"));
  s.frame();
  EXPECT_TRUE(render::style(name).display_skin);
  s.finish();
  const nlohmann::json r = s.report();
  EXPECT_EQ(r["display_skin"], true);
  ASSERT_EQ(r["embedded_drawn"].size(), 3u);
  EXPECT_EQ(r["embedded_drawn"][1]["name"], "vessels");
}

}  // namespace
}  // namespace lamina::cli
