// The GLFW backend: a window on the display with an OpenGL 3.3 core context and Dear ImGui's
// GLFW platform. Its mouse and key events become InputEvents, queued like injected ones.
#include <epoxy/gl.h>
// epoxy first: GLFW must not pull in another GL header.
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <imgui.h>

#include <cstdlib>
#include <string>

#include "gl_drawing.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "viewer_state.h"

namespace lamina::render {
namespace {

// The name render::Input uses for a GLFW key, or "" for keys the viewer does not report.
std::string key_name(int key) {
  if (key >= GLFW_KEY_A && key <= GLFW_KEY_Z) return std::string(1, char('a' + key - GLFW_KEY_A));
  if (key >= GLFW_KEY_0 && key <= GLFW_KEY_9) return std::string(1, char('0' + key - GLFW_KEY_0));
  switch (key) {
    case GLFW_KEY_SPACE:
      return "space";
    case GLFW_KEY_ESCAPE:
      return "escape";
    case GLFW_KEY_ENTER:
      return "enter";
    case GLFW_KEY_LEFT_SHIFT:
    case GLFW_KEY_RIGHT_SHIFT:
      return "shift";
    case GLFW_KEY_LEFT_CONTROL:
    case GLFW_KEY_RIGHT_CONTROL:
      return "ctrl";
    case GLFW_KEY_LEFT_ALT:
    case GLFW_KEY_RIGHT_ALT:
      return "alt";
    default:
      return "";
  }
}

class GlfwBackend final : public ViewerBackend {
 public:
  explicit GlfwBackend(const ViewerOptions& options) : platform_mouse_(options.platform_mouse) {
    check_display();
    const char* display = std::getenv("DISPLAY");
    glfwSetErrorCallback(
        [](int code, const char* text) { log::logger().debug("GLFW {}: {}", code, text); });
    if (!glfwInit())
      throw Error(ErrorKind::kUnavailable,
                  std::string("cannot open the display '") + (display ? display : "") +
                      "': use `lamina render MODEL -o picture.png` for pictures without a window");
    try {
      open_window(options);
      glfwSetWindowUserPointer(window_, this);
      // Ours first: Dear ImGui's callbacks chain to them.
      glfwSetCursorPosCallback(window_, on_cursor);
      glfwSetMouseButtonCallback(window_, on_button);
      glfwSetScrollCallback(window_, on_scroll);
      glfwSetKeyCallback(window_, on_key);
      ImGui_ImplGlfw_InitForOpenGL(window_, true);
      imgui_platform_ = true;
      gl_ = std::make_unique<GlDrawing>();
    } catch (...) {
      close();
      throw;
    }
  }
  ~GlfwBackend() override { close(); }

  void poll_events(std::vector<InputEvent>& out) override {
    glfwPollEvents();
    out.insert(out.end(), pending_.begin(), pending_.end());
    pending_.clear();
  }
  bool close_requested() override { return glfwWindowShouldClose(window_); }
  Eigen::Vector2i window_size() override {
    int w = 0, h = 0;
    glfwGetWindowSize(window_, &w, &h);
    return {w, h};
  }
  Eigen::Vector2i framebuffer_size() override {
    int w = 0, h = 0;
    glfwGetFramebufferSize(window_, &w, &h);
    return {w, h};
  }
  void new_ui_frame() override {
    gl_->new_ui_frame();
    ImGui_ImplGlfw_NewFrame();
  }
  void draw(const std::vector<DrawItem>& items, const Camera& camera, ImDrawData* ui) override {
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    const Eigen::Vector2i fb = framebuffer_size();
    gl_->draw(items, camera, fb.x(), fb.y(), ui);
  }
  Image read_display() override {
    const Eigen::Vector2i fb = framebuffer_size();
    glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
    glReadBuffer(GL_BACK);
    return read_pixels(fb.x(), fb.y());
  }
  Image render_view(const std::vector<DrawItem>& items, const Camera& camera, int width,
                    int height) override {
    return gl_->render_view(items, camera, width, height);
  }
  void present() override { glfwSwapBuffers(window_); }
  void forget(const std::string& name) override { gl_->forget(name); }

 private:
  void open_window(const ViewerOptions& options) {
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    // The window is probed hidden and shown once chosen: a probe window that appeared on the
    // display and vanished a moment later could be the window a client waits for (`xdotool
    // search --sync` found it, then sent its drag to a window that no longer existed).
    glfwWindowHint(GLFW_VISIBLE, GLFW_FALSE);
    // Multisampling is free on a GPU but quadruples the fragment work of Mesa's CPU renderer
    // (measured under Xvfb: 70 ms against 25 ms a 1400x900 frame), so it is dropped there.
    for (int samples : {4, 0}) {
      glfwWindowHint(GLFW_SAMPLES, samples);
      window_ =
          glfwCreateWindow(options.width, options.height, options.title.c_str(), nullptr, nullptr);
      if (!window_) continue;
      glfwMakeContextCurrent(window_);
      const char* gl_renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
      const bool software =
          gl_renderer && (std::string(gl_renderer).find("llvmpipe") != std::string::npos ||
                          std::string(gl_renderer).find("softpipe") != std::string::npos);
      if (samples == 0 || !software) break;
      glfwDestroyWindow(window_);
      window_ = nullptr;
    }
    if (!window_)
      throw Error(
          ErrorKind::kUnavailable,
          "cannot open an OpenGL 3.3 core window on this display: use `lamina render` instead");
    glfwShowWindow(window_);
    glfwSwapInterval(1);
  }

  void close() {
    gl_.reset();
    if (imgui_platform_) ImGui_ImplGlfw_Shutdown();
    imgui_platform_ = false;
    if (window_) glfwDestroyWindow(window_);
    window_ = nullptr;
    glfwTerminate();
  }

  static GlfwBackend& self(GLFWwindow* w) {
    return *static_cast<GlfwBackend*>(glfwGetWindowUserPointer(w));
  }
  static void on_cursor(GLFWwindow* w, double x, double y) {
    GlfwBackend& b = self(w);
    if (b.platform_mouse_) b.pending_.push_back(InputEvent::move_to({x, y}));
  }
  static void on_button(GLFWwindow* w, int button, int action, int) {
    GlfwBackend& b = self(w);
    if (!b.platform_mouse_ || button < 0 || button > 2) return;
    const auto mb = static_cast<MouseButton>(button);  // GLFW: 0 left, 1 right, 2 middle
    b.pending_.push_back(action == GLFW_PRESS ? InputEvent::press(mb) : InputEvent::release(mb));
  }
  static void on_scroll(GLFWwindow* w, double, double dy) {
    GlfwBackend& b = self(w);
    if (b.platform_mouse_) b.pending_.push_back(InputEvent::scroll(dy));
  }
  static void on_key(GLFWwindow* w, int key, int, int action, int) {
    if (action == GLFW_REPEAT) return;
    std::string name = key_name(key);
    if (name.empty()) return;
    self(w).pending_.push_back(action == GLFW_PRESS ? InputEvent::key_down(std::move(name))
                                                    : InputEvent::key_up(std::move(name)));
  }

  GLFWwindow* window_ = nullptr;
  bool imgui_platform_ = false;
  bool platform_mouse_ = true;
  std::unique_ptr<GlDrawing> gl_;
  std::vector<InputEvent> pending_;
};

}  // namespace

void check_display() {
  const char* display = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  if ((!display || !*display) && (!wayland || !*wayland))
    throw Error(ErrorKind::kUnavailable,
                "no display (DISPLAY is not set): use `lamina render MODEL -o picture.png` for "
                "pictures without a window, or run the viewer under xvfb-run");
}

std::unique_ptr<ViewerBackend> make_glfw_backend(const ViewerOptions& options) {
  return std::make_unique<GlfwBackend>(options);
}

}  // namespace lamina::render
