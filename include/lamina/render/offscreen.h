#pragma once
/// \file
/// Rendering without a window: an EGL surfaceless context (Mesa; no X server, no GPU needed) and
/// multisampled framebuffers read back into images, plus PNG output. The viewer uses
/// render_image() too, for screenshots at any size.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "lamina/render/renderer.h"

namespace lamina::render {

/// An 8-bit RGBA image, rows top to bottom.
struct Image {
  int width = 0, height = 0;
  std::vector<uint8_t> rgba;  ///< width * height * 4

  uint8_t* pixel(int x, int y) { return rgba.data() + 4 * (static_cast<size_t>(y) * width + x); }
  const uint8_t* pixel(int x, int y) const {
    return rgba.data() + 4 * (static_cast<size_t>(y) * width + x);
  }
};

/// An OpenGL 3.3 core context with no window, made current on the calling thread while alive.
class HeadlessContext {
 public:
  /// \note Throws lamina::Error (kUnavailable) saying what is missing (EGL, Mesa's surfaceless
  ///   platform, an OpenGL 3.3 core context) and which Debian packages provide it.
  HeadlessContext();
  ~HeadlessContext();
  HeadlessContext(const HeadlessContext&) = delete;
  HeadlessContext& operator=(const HeadlessContext&) = delete;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Draws `frame` into a width x height multisampled framebuffer of the current context and reads
/// it back. The previously bound framebuffer and viewport are restored.
Image render_image(Renderer& renderer, const Frame& frame, const Camera& camera, int width,
                   int height);
/// The same for any drawing: runs `draw(width, height)` with the multisampled framebuffer bound
/// (several models in one picture), then resolves and reads it back.
Image render_image(const std::function<void(int width, int height)>& draw, int width, int height);

/// Reads the bound read framebuffer's width x height pixels (rows top to bottom, opaque).
Image read_pixels(int width, int height);

/// Writes `image` as a PNG, atomically (temp file, then rename).
/// \note Throws lamina::Error (kOutput) naming `path`.
void write_png(const Image& image, const std::string& path);

}  // namespace lamina::render
