#include "gl_drawing.h"

#include <epoxy/gl.h>
// epoxy first: Dear ImGui's OpenGL 3 backend must not load another GL header.
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>

#include <algorithm>

#include "lamina/core/error.h"

namespace lamina::render {

GlDrawing::GlDrawing() {
  if (!ImGui_ImplOpenGL3_Init("#version 330 core"))
    throw Error(ErrorKind::kUnavailable, "Dear ImGui cannot draw with this OpenGL context");
}

GlDrawing::~GlDrawing() {
  renderers_.clear();
  ImGui_ImplOpenGL3_Shutdown();
}

void GlDrawing::new_ui_frame() {
  ImGui_ImplOpenGL3_NewFrame();
}

void GlDrawing::draw(const std::vector<DrawItem>& items, const Camera& camera, int width,
                     int height, ImDrawData* ui) {
  if (width < 1 || height < 1) return;  // a minimised window
  // One depth range for every model of the view, or the models' depths would not compare.
  double radius = 0.0;
  for (const DrawItem& item : items)
    radius = std::max(radius, scene_radius(*item.frame.model, camera));
  if (items.empty()) {
    const Eigen::Vector4f bg = Style{}.background;
    glViewport(0, 0, width, height);
    glClearColor(bg[0], bg[1], bg[2], bg[3]);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  }
  for (size_t i = 0; i < items.size(); ++i) {
    std::unique_ptr<Renderer>& r = renderers_[*items[i].name];
    if (!r) r = std::make_unique<Renderer>();
    r->draw(items[i].frame, camera, width, height,
            {.clear = i == 0, .scene_radius_mm = radius, .upload_vertices = items[i].upload});
  }
  if (ui) ImGui_ImplOpenGL3_RenderDrawData(ui);
}

Image GlDrawing::render_view(const std::vector<DrawItem>& items, const Camera& camera, int width,
                             int height) {
  return render_image([&](int w, int h) { draw(items, camera, w, h, nullptr); }, width, height);
}

}  // namespace lamina::render
