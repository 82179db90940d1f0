// The viewer engine's life and its frame: init() picks the backend, frame_tick() runs input,
// the app's callback and the drawing in that order, so that what the callback sets is drawn in
// the same frame.
#include "lamina/render/viewer.h"

#include <imgui.h>

#include <chrono>
#include <thread>

#include "lamina/core/error.h"
#include "viewer_state.h"

namespace lamina::render {
namespace {

std::unique_ptr<ViewerState> g_state;  // the one engine (Dear ImGui has one context too)

}  // namespace

ViewerState& viewer_state(const char* what) {
  if (!g_state)
    throw Error(ErrorKind::kInternal, std::string("render::") + what + "() before render::init()");
  return *g_state;
}

void init(const ViewerOptions& options) {
  if (g_state)
    throw Error(ErrorKind::kInvalidInput,
                "render::init(): the viewer is already initialized (call render::shutdown() "
                "first)");
  if (options.width < 1 || options.height < 1 || options.width > 16384 || options.height > 16384)
    throw invalid_input("render::init()", "window size " + std::to_string(options.width) + "x" +
                                              std::to_string(options.height) +
                                              " is outside 1..16384 pixels");
  auto s = std::make_unique<ViewerState>();
  s->options = options;
  s->input.mouse_px = Eigen::Vector2d(0.5 * options.width, 0.5 * options.height);
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // leave no imgui.ini behind in the user's folder
  ImGui::StyleColorsDark();
  try {
    switch (options.backend) {
      case Backend::kGlfw:
        s->backend = make_glfw_backend(options);
        break;
      case Backend::kEgl:
        s->backend = make_egl_backend(options);
        break;
      case Backend::kMock:
        s->backend = make_mock_backend(options);
        break;
    }
  } catch (...) {
    ImGui::DestroyContext();
    throw;
  }
  g_state = std::move(s);
}

bool is_initialized() {
  return g_state != nullptr;
}

void shutdown() {
  if (!g_state) return;
  // The backend first: it shuts down its Dear ImGui parts, which need the context.
  g_state->backend.reset();
  ImGui::DestroyContext();
  g_state.reset();
}

void set_callback(std::function<void()> callback) {
  viewer_state("set_callback").callback = std::move(callback);
}

Camera& camera() {
  return viewer_state("camera").camera;
}

Eigen::Vector2i window_size() {
  return viewer_state("window_size").backend->window_size();
}

void request_close() {
  viewer_state("request_close").close = true;
}

int64_t frame_count() {
  return viewer_state("frame_count").frames;
}

const std::vector<DrawnModel>& last_frame() {
  return viewer_state("last_frame").last_frame;
}

std::vector<DrawItem> draw_items(ViewerState& s, bool count_as_frame) {
  std::vector<DrawItem> items;
  if (count_as_frame) s.last_frame.clear();
  for (auto& [name, st] : s.structures) {
    DrawItem item;
    item.name = &name;
    item.frame.model = st.model.get();
    item.frame.x = &st.x;
    for (const Eigen::MatrixX3d& e : st.embedded_x) item.frame.embedded_x.push_back(&e);
    item.frame.rings = st.overlays.rings;
    item.frame.arrows = st.overlays.arrows;
    item.frame.markers = st.overlays.markers;
    item.frame.style = st.style;
    item.upload = st.dirty;
    if (st.dirty) ++st.stats.uploads;
    st.dirty = false;
    if (count_as_frame) {
      ++st.stats.draws;
      s.last_frame.push_back({name, st.model->node_count(), st.overlays, item.upload});
    }
    items.push_back(std::move(item));
  }
  return items;
}

bool frame_tick() {
  ViewerState& s = viewer_state("frame_tick");
  if (s.close || s.backend->close_requested()) {
    s.close = true;
    return false;
  }
  s.backend->poll_events(s.queue);
  apply_input_events(s);
  s.backend->new_ui_frame();
  feed_ui_input(s);
  ImGui::NewFrame();
  const ImGuiIO& io = ImGui::GetIO();
  s.input.ui_wants_mouse = io.WantCaptureMouse;
  s.input.ui_wants_keyboard = io.WantCaptureKeyboard;
  if (s.callback) {
    try {
      s.callback();
    } catch (...) {
      ImGui::EndFrame();  // the next frame can begin
      throw;
    }
  }
  ImGui::Render();
  const std::vector<DrawItem> items = draw_items(s, true);
  s.backend->draw(items, s.camera, ImGui::GetDrawData());
  s.backend->present();
  ++s.frames;
  if (s.backend->close_requested()) s.close = true;
  return !s.close;
}

void show() {
  viewer_state("show");
  using Clock = std::chrono::steady_clock;
  // At most 60 frames a second even where the display has no vertical sync (Xvfb, EGL): a
  // simulation beside the viewer needs the cores more than the screen needs more frames.
  for (;;) {
    const auto start = Clock::now();
    if (!frame_tick()) break;
    std::this_thread::sleep_until(start + std::chrono::microseconds(16667));
  }
}

}  // namespace lamina::render
