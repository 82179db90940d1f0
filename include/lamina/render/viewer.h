#pragma once
/// \file
/// The viewer engine: a window (or an offscreen framebuffer, or nothing at all) that shows
/// registered models and runs the app's Dear ImGui panels, in the shape of Polyscope
/// (nmwsharp/polyscope `polyscope.h`). The engine draws; the app owns its simulation and steps
/// it between frames. Three calls:
///
///     render::init();                                // a GLFW window (or kEgl, kMock)
///     render::register_model("liver", model);        // copied
///     render::show();                                // until the window closes
///
/// or, with the app owning the loop:
///
///     while (render::frame_tick()) {                  // poll, callback (panels), draw
///       sim::step(s);
///       render::update_positions("liver", s.x);       // uploaded at the next frame
///     }
///
/// One engine per process (like Polyscope's): the functions act on it and are called from one
/// thread. Backends are picked at init(): a GLFW window (OpenGL 3.3 core + Dear ImGui), Mesa's
/// surfaceless EGL (frames drawn into an offscreen framebuffer; screenshots, no display), or a
/// mock with no OpenGL at all that records what it was given (tests).

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "lamina/model/model.h"
#include "lamina/render/camera.h"
#include "lamina/render/frame.h"
#include "lamina/render/input.h"
#include "lamina/render/offscreen.h"

namespace lamina::render {

enum class Backend : uint8_t {
  kGlfw,  ///< a window on the display: needs DISPLAY or WAYLAND_DISPLAY
  kEgl,   ///< no window, no display: an offscreen OpenGL 3.3 core framebuffer (Mesa EGL)
  kMock,  ///< no OpenGL: nothing is drawn, everything is recorded; input is injected
};

struct ViewerOptions {
  Backend backend = Backend::kGlfw;
  int width = 1400, height = 900;  ///< the window's (kGlfw) or the framebuffer's size, pixels
  std::string title = "Lamina";    ///< the window's title
  /// false: the window's own mouse events (moves, buttons, wheel) are dropped and only injected
  /// ones count, e.g. while a script drives the mouse. Keys are always taken.
  bool platform_mouse = true;
};

/// Starts the engine with the chosen backend; the camera is fitted to the first model registered.
/// \note Throws lamina::Error (kUnavailable) when the backend cannot start: with kGlfw and no
///   display, the one-line message of check_display(); (kInvalidInput) for a size outside
///   1..16384 or a second init() without shutdown().
void init(const ViewerOptions& options = {});
inline void init(Backend backend) {
  ViewerOptions options;
  options.backend = backend;
  init(options);
}
bool is_initialized();
/// Closes the window, frees the OpenGL and Dear ImGui state and forgets every model, the
/// callback and the input. No-op when not initialized. Not from inside the callback (the frame
/// still runs on the engine): call request_close() there, and shutdown() after the loop.
void shutdown();

/// Throws lamina::Error (kUnavailable) if no display can be reached (DISPLAY and WAYLAND_DISPLAY
/// unset), with a message suggesting `lamina render`. Cheap: call it before long work.
void check_display();

// ---- structures ---------------------------------------------------------------------------

/// Registers (or replaces) a model to show under `name`, drawn at its rest positions until
/// update_positions(). The engine keeps its own copy. A new name is shown with
/// default_style(model); a replaced model keeps its style.
/// \note Throws lamina::Error (kInvalidInput) naming the structure and what arrived when the
///   model cannot be drawn: no nodes, no layers, a non-finite rest position, a face or spring
///   naming a node that does not exist.
void register_model(const std::string& name, const Model& model);
/// Forgets a registered model (no-op if there is none of that name).
void remove_model(const std::string& name);
bool has_model(const std::string& name);

/// New positions for a registered model: copied now, uploaded to the backend at the next frame
/// (once, however many updates came in between).
/// @param[in] x  #nodes by 3, mm
/// \note Throws lamina::Error (kInvalidInput) naming the structure and what arrived for an
///   unknown name, the wrong number of rows, or a non-finite coordinate.
void update_positions(const std::string& name, const Eigen::MatrixX3d& x);
/// The positions the model is drawn at (its rest positions until update_positions()).
const Eigen::MatrixX3d& positions(const std::string& name);
/// Its embedded surfaces' vertices as drawn, one #V by 3 matrix per Model::embedded entry:
/// model::embedded_positions() of positions(name), computed by update_positions() into buffers
/// allocated at registration (rest positions until then).
const std::vector<Eigen::MatrixX3d>& embedded_positions(const std::string& name);

/// What is drawn over a model this frame: the contacts' BFS rings, force arrows, spheres (the
/// tool tip, contacts). Frame's add_force_arrow() and add_contact_marker() compute them.
struct Overlays {
  std::vector<RingHighlight> rings;
  std::vector<Arrow> arrows;
  std::vector<Marker> markers;
};
/// Replaces a model's overlays; they stay until replaced. Ring levels above the model's
/// rings.locality are drawn as locality.
void set_overlays(const std::string& name, Overlays overlays);
/// Replaces a model's drawing style (the first model's background clears the view).
void set_style(const std::string& name, const Style& style);
/// A model's drawing style (default_style(model) until set_style()).
const Style& style(const std::string& name);

// ---- frames -------------------------------------------------------------------------------

/// Called once a frame between the input and the drawing, inside a Dear ImGui frame: the app
/// reads input(), builds its panels with ImGui, moves the camera, updates positions and
/// overlays; what it sets is drawn in the same frame. Empty: no callback.
void set_callback(std::function<void()> callback);

/// One frame: collects the window's events and the injected ones into input(), runs the
/// callback, uploads what changed, draws the models and the panels, and presents.
/// @return false once the window was closed (or request_close() was called); the frame is then
///   not drawn
/// \note Throws whatever the callback throws, with the Dear ImGui frame closed.
bool frame_tick();
/// frame_tick() until the window closes, at most 60 frames a second.
void show();
/// Makes the next frame_tick() (or the current one, from the callback) report the window closed.
void request_close();

/// Queues an input event for the next frame, exactly as if the window had received it.
void inject(const InputEvent& event);
/// The current frame's input (see Input; ui_wants_* are set once the Dear ImGui frame began).
const Input& input();

/// The view's camera: the app may move it (orbit, pan, zoom in camera.h) at any time.
Camera& camera();
/// The window's size in the pixels of Input::mouse_px (kEgl, kMock: the framebuffer's size).
Eigen::Vector2i window_size();

// ---- pictures -----------------------------------------------------------------------------

/// The view at the framebuffer's size, multisampled. with_ui: the window as last presented,
/// the panels of the last frame included. The mock backend returns a picture of the first
/// model's background colour.
/// \note Throws lamina::Error (kUnavailable) when OpenGL cannot make the picture.
Image screenshot_image(bool with_ui = false);
/// screenshot_image() written as a PNG.
/// \note Throws lamina::Error (kOutput) naming `path` when it cannot be written.
void screenshot(const std::string& path, bool with_ui = false);

// ---- what the engine did (tests, reports) -------------------------------------------------

/// Counts for one registered model since it was registered.
struct StructureStats {
  int64_t updates = 0;  ///< update_positions() calls
  int64_t uploads = 0;  ///< frames that sent its vertices (positions, normals, colours) again
  int64_t draws = 0;    ///< frames that drew it
};
StructureStats structure_stats(const std::string& name);

/// One model as the backend was asked to draw it in the last frame.
struct DrawnModel {
  std::string name;
  int32_t nodes = 0;
  Overlays overlays;
  bool uploaded = false;  ///< its vertices were sent in that frame
};
/// What the last frame drew, model by model in name order.
const std::vector<DrawnModel>& last_frame();
/// Frames drawn since init().
int64_t frame_count();

}  // namespace lamina::render
