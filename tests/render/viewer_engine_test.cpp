// The viewer engine (render/viewer.h) on its mock backend, with no display and no OpenGL: what is
// registered is copied and checked, an update is uploaded once at the next frame, injected input
// reaches the callback (and Dear ImGui) as a window's would, and a missing display with the GLFW
// backend is the one-line error that suggests `lamina render`. Then the EGL backend: frames,
// panels and screenshots with no display.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <imgui.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>

#include "lamina/core/error.h"
#include "lamina/render/viewer.h"
#include "support/sphere_model.h"
#include "support/temp_dir.h"

namespace lamina::render {
namespace {

using ::testing::HasSubstr;

// Every test starts and ends with no engine, whatever it throws.
class ViewerEngine : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_FALSE(is_initialized()); }
  void TearDown() override { shutdown(); }
};

// The message of the lamina::Error `f` throws, and its kind.
template <class F>
std::optional<std::pair<ErrorKind, std::string>> error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return std::pair{e.kind(), std::string(e.what())};
  }
  return std::nullopt;
}

TEST_F(ViewerEngine, PositionsAreUploadedOnceAtTheNextFrameAfterAnUpdate) {
  init(Backend::kMock);
  const Model& m = test::sphere_model();
  register_model("liver", m);
  EXPECT_TRUE(has_model("liver"));
  ASSERT_TRUE(frame_tick());
  EXPECT_EQ(structure_stats("liver").uploads, 1) << "a new model is sent once";
  ASSERT_TRUE(frame_tick());
  ASSERT_TRUE(frame_tick());
  EXPECT_EQ(structure_stats("liver").uploads, 1) << "unchanged positions were sent again";
  EXPECT_FALSE(last_frame().at(0).uploaded);

  Eigen::MatrixX3d x = m.X;
  x.col(2).array() += 5.0;
  update_positions("liver", x);
  EXPECT_EQ(structure_stats("liver").uploads, 1) << "uploaded before the frame";
  ASSERT_TRUE(frame_tick());
  EXPECT_EQ(structure_stats("liver").uploads, 2);
  EXPECT_TRUE(last_frame().at(0).uploaded);
  EXPECT_EQ(positions("liver"), x);

  // Three updates within one frame are one upload, of the last.
  for (double dz : {1.0, 2.0, 3.0}) {
    x.col(2).array() += dz;
    update_positions("liver", x);
  }
  ASSERT_TRUE(frame_tick());
  const StructureStats st = structure_stats("liver");
  EXPECT_EQ(st.updates, 4);
  EXPECT_EQ(st.uploads, 3);
  EXPECT_EQ(st.draws, 5);
  EXPECT_EQ(frame_count(), 5);
  EXPECT_EQ(positions("liver"), x);
  // The engine keeps a copy: the caller's matrix is its own again.
  x.setZero();
  EXPECT_NE(positions("liver"), x);
}

TEST_F(ViewerEngine, RingsAndStyleChangeTheVerticesButArrowsDoNot) {
  init(Backend::kMock);
  register_model("liver", test::sphere_model());
  ASSERT_TRUE(frame_tick());
  Overlays o;
  o.arrows.push_back({});
  o.markers.push_back({});
  set_overlays("liver", o);
  ASSERT_TRUE(frame_tick());
  EXPECT_EQ(structure_stats("liver").uploads, 1) << "arrows and spheres cost no vertex upload";
  ASSERT_EQ(last_frame().size(), 1u);
  EXPECT_EQ(last_frame()[0].overlays.arrows.size(), 1u);
  EXPECT_EQ(last_frame()[0].overlays.markers.size(), 1u);
  o.rings.push_back({0, 2});
  set_overlays("liver", o);
  ASSERT_TRUE(frame_tick());
  EXPECT_EQ(structure_stats("liver").uploads, 2) << "rings colour the vertices";
  Style s;
  s.coloring = Coloring::kDisplacement;
  set_style("liver", s);
  set_style("liver", s);
  ASSERT_TRUE(frame_tick());
  EXPECT_EQ(structure_stats("liver").uploads, 3);
}

TEST_F(ViewerEngine, BadRegistrationsNameTheStructureAndWhatArrived) {
  init(Backend::kMock);
  const Model& m = test::sphere_model();
  register_model("liver", m);
  const int n = m.node_count();

  auto e = error_of([&] { update_positions("liver", Eigen::MatrixX3d::Zero(100, 3)); });
  ASSERT_TRUE(e);
  EXPECT_EQ(e->first, ErrorKind::kInvalidInput);
  EXPECT_THAT(e->second, HasSubstr("update_positions(\"liver\")"));
  EXPECT_THAT(e->second, HasSubstr("expected " + std::to_string(n) + " rows"));
  EXPECT_THAT(e->second, HasSubstr("got 100"));

  Eigen::MatrixX3d x = m.X;
  x(17, 1) = std::numeric_limits<double>::quiet_NaN();
  e = error_of([&] { update_positions("liver", x); });
  ASSERT_TRUE(e);
  EXPECT_THAT(e->second, HasSubstr("\"liver\""));
  EXPECT_THAT(e->second, HasSubstr("row 17"));
  EXPECT_THAT(e->second, HasSubstr("nan"));
  EXPECT_EQ(positions("liver"), m.X) << "a refused update changed what is drawn";
  EXPECT_EQ(structure_stats("liver").updates, 0);

  e = error_of([&] { update_positions("kidney", m.X); });
  ASSERT_TRUE(e);
  EXPECT_THAT(e->second, HasSubstr("\"kidney\""));
  EXPECT_THAT(e->second, HasSubstr("registered: \"liver\""));

  Model bad = m;
  bad.X(3, 0) = std::numeric_limits<double>::infinity();
  e = error_of([&] { register_model("bad", bad); });
  ASSERT_TRUE(e);
  EXPECT_EQ(e->first, ErrorKind::kInvalidInput);
  EXPECT_THAT(e->second, HasSubstr("register_model(\"bad\")"));
  EXPECT_THAT(e->second, HasSubstr("row 3"));
  bad = m;
  bad.layers[0].F(5, 1) = n + 7;
  e = error_of([&] { register_model("bad", bad); });
  ASSERT_TRUE(e);
  EXPECT_THAT(e->second, HasSubstr("layer 0 has a face naming node " + std::to_string(n + 7)));
  bad = m;
  bad.layers.clear();
  e = error_of([&] { register_model("bad", bad); });
  ASSERT_TRUE(e);
  EXPECT_THAT(e->second, HasSubstr("no layers"));
  EXPECT_FALSE(has_model("bad")) << "a refused model was registered";
}

TEST_F(ViewerEngine, InjectedInputReachesTheCallbackAsAWindowsWould) {
  ViewerOptions o;
  o.backend = Backend::kMock;
  o.width = 800;
  o.height = 600;
  init(o);
  register_model("liver", test::sphere_model());
  EXPECT_EQ(window_size(), Eigen::Vector2i(800, 600));
  Input seen;
  int calls = 0;
  set_callback([&] {
    seen = input();
    ++calls;
    ImGui::SetNextWindowPos(ImVec2(0, 0));
    ImGui::SetNextWindowSize(ImVec2(200, 200));
    ImGui::Begin("panel");
    ImGui::Text("a panel in the top left corner");
    ImGui::End();
  });
  ASSERT_TRUE(frame_tick());
  EXPECT_EQ(calls, 1);

  // A click shorter than a frame is seen over two frames (the input is trickled): the press
  // where it happened, then the release with what followed it.
  inject(InputEvent::move_to({400, 300}));
  inject(InputEvent::press(MouseButton::kLeft));
  inject(InputEvent::release(MouseButton::kLeft));
  inject(InputEvent::key_down("shift"));
  inject(InputEvent::scroll(1.0));
  inject(InputEvent::scroll(2.0));
  inject(InputEvent::key_down("r"));
  inject(InputEvent::key_up("r"));
  ASSERT_TRUE(frame_tick());
  EXPECT_EQ(seen.mouse_px, Eigen::Vector2d(400, 300));
  EXPECT_TRUE(seen.went_down(MouseButton::kLeft));
  EXPECT_TRUE(seen.down(MouseButton::kLeft));
  EXPECT_FALSE(seen.released[0]);
  EXPECT_FALSE(seen.shift) << "what followed the press is the next frame's";
  ASSERT_TRUE(frame_tick());
  EXPECT_FALSE(seen.went_down(MouseButton::kLeft));
  EXPECT_TRUE(seen.released[0]);
  EXPECT_FALSE(seen.down(MouseButton::kLeft));
  EXPECT_FALSE(seen.shift);
  ASSERT_TRUE(frame_tick());
  EXPECT_TRUE(seen.shift);
  EXPECT_DOUBLE_EQ(seen.wheel, 3.0);
  ASSERT_EQ(seen.keys.size(), 1u);
  EXPECT_EQ(seen.keys[0], "r");
  EXPECT_FALSE(seen.ui_wants_mouse) << "no panel under (400, 300)";

  // The per-frame changes last one frame; held state stays.
  inject(InputEvent::press(MouseButton::kRight));
  ASSERT_TRUE(frame_tick());
  ASSERT_TRUE(frame_tick());
  EXPECT_FALSE(seen.went_down(MouseButton::kRight));
  EXPECT_TRUE(seen.down(MouseButton::kRight));
  EXPECT_TRUE(seen.shift);
  EXPECT_EQ(seen.wheel, 0.0);
  EXPECT_TRUE(seen.keys.empty());
  inject(InputEvent::release(MouseButton::kRight));

  // Over the panel, Dear ImGui wants the mouse: the same pointer moves it and the app.
  inject(InputEvent::move_to({50, 50}));
  ASSERT_TRUE(frame_tick());
  ASSERT_TRUE(frame_tick());
  EXPECT_TRUE(seen.ui_wants_mouse);
  inject(InputEvent::move_to({600, 500}));
  ASSERT_TRUE(frame_tick());
  EXPECT_FALSE(seen.ui_wants_mouse);
}

// A whole drag that arrives within one slow frame (a loaded or sanitized machine draws a frame
// a second): the press is seen where it happened, the moves a frame later with the button still
// down, the release after them, and Shift let go after the release only after it.
TEST_F(ViewerEngine, ADragWithinOneFrameIsSeenPressMovesAndReleaseInTurn) {
  init(Backend::kMock);
  Input seen;
  set_callback([&] { seen = input(); });
  inject(InputEvent::move_to({100, 100}));
  ASSERT_TRUE(frame_tick());
  inject(InputEvent::key_down("shift"));
  inject(InputEvent::press(MouseButton::kLeft));
  for (int k = 1; k <= 5; ++k) inject(InputEvent::move_to({100.0, 100.0 - 10.0 * k}));
  inject(InputEvent::release(MouseButton::kLeft));
  inject(InputEvent::key_up("shift"));
  ASSERT_TRUE(frame_tick());
  EXPECT_TRUE(seen.went_down(MouseButton::kLeft));
  EXPECT_EQ(seen.mouse_px, Eigen::Vector2d(100, 100)) << "the press is where it happened";
  EXPECT_TRUE(seen.shift);
  ASSERT_TRUE(frame_tick());
  EXPECT_EQ(seen.mouse_px, Eigen::Vector2d(100, 50));
  EXPECT_TRUE(seen.down(MouseButton::kLeft)) << "the drag's end is seen before its release";
  EXPECT_FALSE(seen.released[0]);
  ASSERT_TRUE(frame_tick());
  EXPECT_TRUE(seen.released[0]);
  EXPECT_TRUE(seen.shift) << "Shift was let go after the release";
  ASSERT_TRUE(frame_tick());
  EXPECT_FALSE(seen.shift);
  EXPECT_FALSE(seen.released[0]);
}

TEST_F(ViewerEngine, CameraFitsTheFirstModelAndCloseEndsTheFrames) {
  init(Backend::kMock);
  const Model& m = test::sphere_model();
  register_model("liver", m);
  const Camera fitted = fit_camera(m);
  EXPECT_EQ(camera().target, fitted.target);
  EXPECT_DOUBLE_EQ(camera().distance_mm, fitted.distance_mm);
  orbit(camera(), 30.0, 0.0);
  Model moved = m;
  moved.X.col(0).array() += 500.0;
  register_model("liver", moved);  // a replacement keeps the user's view
  EXPECT_DOUBLE_EQ(camera().azimuth_deg, fitted.azimuth_deg + 30.0);
  EXPECT_EQ(camera().target, fitted.target);
  EXPECT_EQ(positions("liver"), moved.X);

  int calls = 0;
  set_callback([&] {
    if (++calls == 2) request_close();
  });
  EXPECT_TRUE(frame_tick());
  EXPECT_FALSE(frame_tick()) << "closed from the callback: this frame is the last";
  EXPECT_FALSE(frame_tick());
  EXPECT_EQ(calls, 2);
  show();  // returns at once: the window is closed
  EXPECT_EQ(calls, 2);
}

TEST_F(ViewerEngine, UseBeforeInitAndASecondInitAreErrors) {
  auto e = error_of([] { register_model("liver", test::sphere_model()); });
  ASSERT_TRUE(e);
  EXPECT_THAT(e->second, HasSubstr("render::register_model() before render::init()"));
  e = error_of([] { frame_tick(); });
  ASSERT_TRUE(e);
  init(Backend::kMock);
  e = error_of([] { init(Backend::kMock); });
  ASSERT_TRUE(e);
  EXPECT_THAT(e->second, HasSubstr("already initialized"));
  shutdown();
  EXPECT_FALSE(is_initialized());
  e = error_of([] {
    ViewerOptions o;
    o.backend = Backend::kMock;
    o.width = 0;
    init(o);
  });
  ASSERT_TRUE(e);
  EXPECT_THAT(e->second, HasSubstr("0x900"));
  EXPECT_FALSE(is_initialized());
}

TEST_F(ViewerEngine, GlfwWithoutADisplaySaysUseLaminaRender) {
  // The environment is this process's own: restored whatever happens.
  struct Env {
    std::string display, wayland;
    bool had_display = std::getenv("DISPLAY"), had_wayland = std::getenv("WAYLAND_DISPLAY");
    Env() {
      if (had_display) display = std::getenv("DISPLAY");
      if (had_wayland) wayland = std::getenv("WAYLAND_DISPLAY");
      unsetenv("DISPLAY");
      unsetenv("WAYLAND_DISPLAY");
    }
    ~Env() {
      if (had_display) setenv("DISPLAY", display.c_str(), 1);
      if (had_wayland) setenv("WAYLAND_DISPLAY", wayland.c_str(), 1);
    }
  } env;
  const auto e = error_of([] { init(Backend::kGlfw); });
  ASSERT_TRUE(e);
  EXPECT_EQ(e->first, ErrorKind::kUnavailable);
  EXPECT_THAT(e->second, HasSubstr("no display"));
  EXPECT_THAT(e->second, HasSubstr("lamina render"));
  EXPECT_EQ(e->second.find('\n'), std::string::npos) << "one line";
  EXPECT_FALSE(is_initialized());
  init(Backend::kMock);  // and nothing of the failed start is left behind
  EXPECT_TRUE(frame_tick());
}

TEST_F(ViewerEngine, MockScreenshotsArePicturesOfTheBackground) {
  init(Backend::kMock);
  register_model("liver", test::sphere_model());
  Style s;
  s.background = {1.0f, 1.0f, 1.0f, 1.0f};
  set_style("liver", s);
  ASSERT_TRUE(frame_tick());
  const Image img = screenshot_image();
  ASSERT_EQ(img.width, 1400);
  ASSERT_EQ(img.height, 900);
  EXPECT_EQ(img.pixel(700, 450)[0], 255);
  test::TempDir dir;
  screenshot(dir.file("shot.png"), true);
  EXPECT_TRUE(std::filesystem::exists(dir.file("shot.png")));
}

// ---- EGL: the same engine drawing with OpenGL and no display ------------------------------

// Share of pixels that differ from `background` by more than a few levels.
double coverage(const Image& img, const Eigen::Vector4f& background, int x0 = 0, int y0 = 0,
                int x1 = -1, int y1 = -1) {
  if (x1 < 0) x1 = img.width;
  if (y1 < 0) y1 = img.height;
  int64_t n = 0;
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      const uint8_t* p = img.pixel(x, y);
      for (int c = 0; c < 3; ++c)
        if (std::abs(p[c] - static_cast<int>(std::lround(255 * background[c]))) > 3) {
          ++n;
          break;
        }
    }
  return static_cast<double>(n) / (static_cast<double>(x1 - x0) * (y1 - y0));
}

TEST_F(ViewerEngine, EglDrawsFramesPanelsAndSeveralModelsWithNoDisplay) {
  ViewerOptions o;
  o.backend = Backend::kEgl;
  o.width = 320;
  o.height = 240;
  init(o);
  const Model& m = test::sphere_model();
  register_model("a", m);
  bool panel = false;
  set_callback([&] {
    if (!panel) return;
    ImGui::SetNextWindowPos(ImVec2(0, 0));
    ImGui::SetNextWindowSize(ImVec2(120, 100));
    ImGui::Begin("panel");
    ImGui::Text("hello");
    ImGui::End();
  });
  ASSERT_TRUE(frame_tick());
  const Eigen::Vector4f bg = Style{}.background;
  const Image one = screenshot_image();
  ASSERT_EQ(one.width, 320);
  const double c1 = coverage(one, bg);
  EXPECT_GT(c1, 0.05) << "the organ is not in the picture";
  EXPECT_LT(c1, 0.9);

  // The window as presented: the panel shows in its corner only with the UI.
  panel = true;
  ASSERT_TRUE(frame_tick());
  const Image with_ui = screenshot_image(true), without = screenshot_image(false);
  EXPECT_GT(coverage(with_ui, bg, 5, 5, 110, 90), 0.5) << "no panel drawn";
  EXPECT_LT(coverage(without, bg, 5, 5, 110, 90), coverage(with_ui, bg, 5, 5, 110, 90) - 0.3);

  // A second model beside the first: both in one view, neither clearing the other.
  Model moved = m;
  moved.X.col(0).array() += 30.0;
  register_model("b", moved);
  camera().distance_mm *= 1.6;
  const double both = coverage(screenshot_image(), bg);
  remove_model("b");
  const double only_a = coverage(screenshot_image(), bg);
  EXPECT_GT(both, 1.3 * only_a) << "the second model was not drawn over the first";

  // A deformed organ is a different picture once its positions are updated.
  Eigen::MatrixX3d x = m.X;
  x.col(2) *= 1.5;
  x.col(2).array() -= 0.5 * m.X.col(2).mean();
  update_positions("a", x);
  ASSERT_TRUE(frame_tick());
  EXPECT_EQ(structure_stats("a").uploads, 2);
  EXPECT_NE(coverage(screenshot_image(), bg), only_a);
  test::TempDir dir;
  screenshot(dir.file("egl.png"));
  EXPECT_GT(std::filesystem::file_size(dir.file("egl.png")), 1000u);
}

}  // namespace
}  // namespace lamina::render
