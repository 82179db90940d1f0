#pragma once
// What the two OpenGL backends (a GLFW window, an EGL framebuffer) share: a renderer per
// registered model, the models drawn into one view with one depth range, and Dear ImGui's
// OpenGL 3 renderer for the panels. Needs a current OpenGL 3.3 core context throughout.

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "lamina/render/renderer.h"
#include "viewer_state.h"

namespace lamina::render {

class GlDrawing {
 public:
  GlDrawing();   ///< starts Dear ImGui's OpenGL 3 renderer (the context must exist)
  ~GlDrawing();  ///< stops it
  GlDrawing(const GlDrawing&) = delete;
  GlDrawing& operator=(const GlDrawing&) = delete;

  void new_ui_frame();
  /// Draws the items into the bound framebuffer's width x height viewport, then `ui`.
  void draw(const std::vector<DrawItem>& items, const Camera& camera, int width, int height,
            ImDrawData* ui);
  /// The items alone into an offscreen multisampled framebuffer, read back.
  Image render_view(const std::vector<DrawItem>& items, const Camera& camera, int width,
                    int height);
  void forget(const std::string& name) { renderers_.erase(name); }

 private:
  std::map<std::string, std::unique_ptr<Renderer>> renderers_;
};

}  // namespace lamina::render
