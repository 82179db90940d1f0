// The EGL backend: no window and no display. Mesa's surfaceless EGL context (HeadlessContext)
// with a framebuffer object standing in for the window: frames, panels and screenshots are drawn
// as they would be on screen, and input comes only from inject().
#include <epoxy/gl.h>

#include "gl_drawing.h"
#include "lamina/core/error.h"
#include "viewer_state.h"

namespace lamina::render {
namespace {

class EglBackend final : public ViewerBackend {
 public:
  explicit EglBackend(const ViewerOptions& options)
      : width_(options.width), height_(options.height) {
    glGenFramebuffers(1, &fbo_);
    glGenRenderbuffers(2, rbo_);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
    glBindRenderbuffer(GL_RENDERBUFFER, rbo_[0]);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width_, height_);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, rbo_[0]);
    glBindRenderbuffer(GL_RENDERBUFFER, rbo_[1]);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, width_, height_);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, rbo_[1]);
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
      release();
      throw Error(ErrorKind::kUnavailable, "OpenGL: the viewer's offscreen framebuffer of " +
                                               std::to_string(width_) + "x" +
                                               std::to_string(height_) + " is incomplete");
    }
    try {
      gl_ = std::make_unique<GlDrawing>();
    } catch (...) {
      release();
      throw;
    }
  }
  ~EglBackend() override {
    gl_.reset();
    release();
  }

  void poll_events(std::vector<InputEvent>&) override {}
  bool close_requested() override { return false; }
  Eigen::Vector2i window_size() override { return {width_, height_}; }
  Eigen::Vector2i framebuffer_size() override { return {width_, height_}; }
  void new_ui_frame() override { gl_->new_ui_frame(); }
  void draw(const std::vector<DrawItem>& items, const Camera& camera, ImDrawData* ui) override {
    glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
    gl_->draw(items, camera, width_, height_, ui);
  }
  Image read_display() override {
    glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
    return read_pixels(width_, height_);
  }
  Image render_view(const std::vector<DrawItem>& items, const Camera& camera, int width,
                    int height) override {
    return gl_->render_view(items, camera, width, height);
  }
  void present() override { glFlush(); }
  void forget(const std::string& name) override { gl_->forget(name); }

 private:
  void release() {
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glDeleteFramebuffers(1, &fbo_);
    glDeleteRenderbuffers(2, rbo_);
  }

  HeadlessContext context_;  // first: made before, and destroyed after, everything below
  int width_, height_;
  GLuint fbo_ = 0, rbo_[2] = {};
  std::unique_ptr<GlDrawing> gl_;
};

}  // namespace

std::unique_ptr<ViewerBackend> make_egl_backend(const ViewerOptions& options) {
  return std::make_unique<EglBackend>(options);
}

}  // namespace lamina::render
