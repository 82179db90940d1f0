#pragma once
// The viewer engine's state and the interface its backends implement (module render, private).
// The engine (viewer*.cpp) owns the structures, the input queue, the Dear ImGui context and the
// camera, and decides what to upload; a backend only opens its surface, collects its events and
// draws what it is handed: render/engine.h and initialize_backend.cpp in nmwsharp/polyscope are
// the model.

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "lamina/render/viewer.h"

struct ImDrawData;

namespace lamina::render {

/// A registered model and what is drawn over it.
struct Structure {
  std::unique_ptr<Model> model;  // stable address: the GL backend caches its buffers by it
  Eigen::MatrixX3d x;
  std::vector<Eigen::MatrixX3d> embedded_x;  // per model->embedded: its vertices at x, reused
  Overlays overlays;
  Style style;
  bool dirty = true;  // vertices (positions, normals, colours) changed since the last upload
  StructureStats stats;
};

/// One structure as a backend draws it this frame.
struct DrawItem {
  const std::string* name = nullptr;
  Frame frame;          // model, positions, overlays, style
  bool upload = false;  // send its vertices again (they changed since the last draw)
};

class ViewerBackend {
 public:
  virtual ~ViewerBackend() = default;
  /// Appends the surface's input events since the last call (a window's mouse and keys).
  virtual void poll_events(std::vector<InputEvent>& out) = 0;
  /// The user closed the window.
  virtual bool close_requested() = 0;
  virtual Eigen::Vector2i window_size() = 0;
  virtual Eigen::Vector2i framebuffer_size() = 0;
  /// The backend's share of starting a Dear ImGui frame (its renderer's and platform's
  /// NewFrame); the engine then feeds the input and calls ImGui::NewFrame().
  virtual void new_ui_frame() = 0;
  /// Draws the items (the first clears) and then `ui` (may be null) into the display.
  virtual void draw(const std::vector<DrawItem>& items, const Camera& camera, ImDrawData* ui) = 0;
  /// The display as last drawn, before it is presented.
  virtual Image read_display() = 0;
  /// The items alone, offscreen and multisampled, at width x height.
  virtual Image render_view(const std::vector<DrawItem>& items, const Camera& camera, int width,
                            int height) = 0;
  /// Shows the drawn display (swaps a window's buffers).
  virtual void present() = 0;
  /// Drops what the backend keeps for a structure (its buffers), e.g. before it is replaced.
  virtual void forget(const std::string& name) = 0;
};

std::unique_ptr<ViewerBackend> make_glfw_backend(const ViewerOptions& options);
std::unique_ptr<ViewerBackend> make_egl_backend(const ViewerOptions& options);
std::unique_ptr<ViewerBackend> make_mock_backend(const ViewerOptions& options);

struct ViewerState {
  ViewerOptions options;
  std::unique_ptr<ViewerBackend> backend;
  std::map<std::string, Structure> structures;  // drawn in name order
  std::function<void()> callback;
  Camera camera;
  bool camera_fitted = false;
  bool close = false;
  std::vector<InputEvent> queue;  // injected and platform events for the next frame
  Input input;
  std::vector<DrawnModel> last_frame;
  int64_t frames = 0;
  double last_frame_time_s = -1.0;  // for Dear ImGui's DeltaTime
};

/// The engine; throws lamina::Error (kInternal) "render::<what>() before render::init()" when it
/// was not started.
ViewerState& viewer_state(const char* what);
/// The structure called `name`; throws lamina::Error (kInvalidInput) naming `what` and `name`.
Structure& find_structure(ViewerState& s, const std::string& name, const char* what);

/// Applies the queued events to s.input (clearing the per-frame changes first).
void apply_input_events(ViewerState& s);
/// Hands s.input to Dear ImGui (pointer, buttons, wheel, modifiers, display size, time step).
void feed_ui_input(ViewerState& s);
/// The structures as this frame draws them; marks them uploaded.
std::vector<DrawItem> draw_items(ViewerState& s, bool count_as_frame);

}  // namespace lamina::render
