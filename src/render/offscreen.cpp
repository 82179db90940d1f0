#include "lamina/render/offscreen.h"

#include <epoxy/egl.h>
#include <epoxy/gl.h>
#include <stb/stb_image_write.h>

#include <algorithm>
#include <cstring>
#include <ostream>
#include <string>

#include "lamina/core/atomic_file.h"
#include "lamina/core/error.h"

namespace lamina::render {
namespace {

Error unavailable(const std::string& what) {
  return Error(ErrorKind::kUnavailable,
               "headless rendering: " + what +
                   " (Mesa's EGL is needed: apt-get install libegl-mesa0 libgl1-mesa-dri)");
}

bool has_extension(const char* list, const char* name) {
  if (!list) return false;
  const size_t n = std::strlen(name);
  for (const char* p = list; (p = std::strstr(p, name)); p += n)
    if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
  return false;
}

}  // namespace

struct HeadlessContext::Impl {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
};

HeadlessContext::HeadlessContext() : impl_(std::make_unique<Impl>()) {
  // Mesa's surfaceless platform needs no X server and no GPU (llvmpipe renders on the CPU).
  const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (!has_extension(client, "EGL_MESA_platform_surfaceless"))
    throw unavailable("EGL has no surfaceless platform (EGL_MESA_platform_surfaceless)");
  Impl& r = *impl_;
  r.display = eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  EGLint major = 0, minor = 0;
  if (r.display == EGL_NO_DISPLAY || !eglInitialize(r.display, &major, &minor))
    throw unavailable("cannot open the EGL surfaceless display");
  if (!eglBindAPI(EGL_OPENGL_API)) throw unavailable("EGL cannot bind desktop OpenGL");
  // eglChooseConfig defaults to window surfaces, which the surfaceless platform has none of.
  const EGLint config_attribs[] = {EGL_SURFACE_TYPE,
                                   EGL_PBUFFER_BIT,
                                   EGL_RENDERABLE_TYPE,
                                   EGL_OPENGL_BIT,
                                   EGL_RED_SIZE,
                                   8,
                                   EGL_GREEN_SIZE,
                                   8,
                                   EGL_BLUE_SIZE,
                                   8,
                                   EGL_NONE};
  EGLConfig config = nullptr;
  EGLint configs = 0;
  if (!eglChooseConfig(r.display, config_attribs, &config, 1, &configs) || configs < 1)
    throw unavailable("no EGL configuration for desktop OpenGL");
  const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION,
                                    3,
                                    EGL_CONTEXT_MINOR_VERSION,
                                    3,
                                    EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                    EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                    EGL_NONE};
  r.context = eglCreateContext(r.display, config, EGL_NO_CONTEXT, context_attribs);
  if (r.context == EGL_NO_CONTEXT)
    throw unavailable("EGL cannot create an OpenGL 3.3 core context");
  if (!eglMakeCurrent(r.display, EGL_NO_SURFACE, EGL_NO_SURFACE, r.context))
    throw unavailable("EGL cannot make a context current without a surface");
}

HeadlessContext::~HeadlessContext() {
  Impl& r = *impl_;
  eglMakeCurrent(r.display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  if (r.context != EGL_NO_CONTEXT) eglDestroyContext(r.display, r.context);
  // The display is not terminated: EGL shares one display per process (the next context reuses
  // it), and eglTerminate unloads Mesa's driver with allocations still held, which LeakSanitizer
  // then reports against whatever library was mapped at the driver's old addresses.
}

Image render_image(Renderer& renderer, const Frame& frame, const Camera& camera, int width,
                   int height) {
  return render_image([&](int w, int h) { renderer.draw(frame, camera, w, h); }, width, height);
}

Image render_image(const std::function<void(int width, int height)>& draw, int width, int height) {
  if (width < 1 || height < 1 || width > 16384 || height > 16384)
    throw invalid_input("image size", std::to_string(width) + "x" + std::to_string(height) +
                                          " is outside 1..16384 pixels");
  GLint old_draw = 0, old_read = 0, old_viewport[4] = {};
  glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &old_draw);
  glGetIntegerv(GL_READ_FRAMEBUFFER_BINDING, &old_read);
  glGetIntegerv(GL_VIEWPORT, old_viewport);

  // Draw multisampled (smooth silhouettes and lines), then resolve into a plain framebuffer.
  GLint max_samples = 0;
  glGetIntegerv(GL_MAX_SAMPLES, &max_samples);
  const GLsizei samples = std::min(4, std::max(max_samples, 0));
  GLuint fbo[2] = {}, rbo[3] = {};
  glGenFramebuffers(2, fbo);
  glGenRenderbuffers(3, rbo);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo[0]);
  glBindRenderbuffer(GL_RENDERBUFFER, rbo[0]);
  glRenderbufferStorageMultisample(GL_RENDERBUFFER, samples, GL_RGBA8, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, rbo[0]);
  glBindRenderbuffer(GL_RENDERBUFFER, rbo[1]);
  glRenderbufferStorageMultisample(GL_RENDERBUFFER, samples, GL_DEPTH_COMPONENT24, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, rbo[1]);
  const bool complete = glCheckFramebufferStatus(GL_FRAMEBUFFER) == GL_FRAMEBUFFER_COMPLETE;
  if (complete) draw(width, height);

  glBindFramebuffer(GL_FRAMEBUFFER, fbo[1]);
  glBindRenderbuffer(GL_RENDERBUFFER, rbo[2]);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, rbo[2]);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo[0]);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, fbo[1]);
  glBlitFramebuffer(0, 0, width, height, 0, 0, width, height, GL_COLOR_BUFFER_BIT, GL_NEAREST);

  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo[1]);
  Image img = read_pixels(width, height);

  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, static_cast<GLuint>(old_draw));
  glBindFramebuffer(GL_READ_FRAMEBUFFER, static_cast<GLuint>(old_read));
  glViewport(old_viewport[0], old_viewport[1], old_viewport[2], old_viewport[3]);
  glDeleteFramebuffers(2, fbo);
  glDeleteRenderbuffers(3, rbo);
  if (!complete)
    throw Error(ErrorKind::kUnavailable, "OpenGL: the offscreen framebuffer is incomplete");
  return img;
}

Image read_pixels(int width, int height) {
  Image img;
  img.width = width;
  img.height = height;
  img.rgba.resize(static_cast<size_t>(width) * height * 4);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, img.rgba.data());
  // OpenGL's rows run bottom to top; images run top to bottom.
  const size_t row = static_cast<size_t>(width) * 4;
  for (int y = 0; y < height / 2; ++y)
    std::swap_ranges(img.rgba.begin() + y * row, img.rgba.begin() + (y + 1) * row,
                     img.rgba.begin() + (height - 1 - y) * row);
  for (size_t i = 3; i < img.rgba.size(); i += 4) img.rgba[i] = 255;  // a window's alpha is noise
  return img;
}

void write_png(const Image& image, const std::string& path) {
  if (image.width < 1 || image.height < 1 ||
      image.rgba.size() != static_cast<size_t>(image.width) * image.height * 4)
    throw Error(ErrorKind::kInternal, path + ": image has no pixels or the wrong size");
  write_file_atomically(
      path,
      [&](std::ostream& out) {
        auto sink = [](void* context, void* data, int size) {
          static_cast<std::ostream*>(context)->write(static_cast<const char*>(data), size);
        };
        if (!stbi_write_png_to_func(sink, &out, image.width, image.height, 4, image.rgba.data(),
                                    image.width * 4))
          throw Error(ErrorKind::kOutput, path + ": PNG encoding failed");
      },
      /*binary=*/true);
}

}  // namespace lamina::render
