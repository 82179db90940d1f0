// Screenshots: the 3-D view drawn again offscreen at the framebuffer's size (multisampled, so a
// picture is smoother than the window on Mesa, which draws the window without), or the window
// with the last frame's panels, drawn again and read back before anything is presented.
#include <imgui.h>

#include "lamina/render/viewer.h"
#include "viewer_state.h"

namespace lamina::render {

Image screenshot_image(bool with_ui) {
  ViewerState& s = viewer_state("screenshot");
  const std::vector<DrawItem> items = draw_items(s, false);
  const Eigen::Vector2i fb = s.backend->framebuffer_size();
  if (!with_ui) return s.backend->render_view(items, s.camera, fb.x(), fb.y());
  // Dear ImGui's draw data stays valid from one Render() to the next NewFrame().
  ImDrawData* ui = ImGui::GetDrawData();
  s.backend->draw(items, s.camera, ui && ui->Valid ? ui : nullptr);
  return s.backend->read_display();
}

void screenshot(const std::string& path, bool with_ui) {
  write_png(screenshot_image(with_ui), path);
}

}  // namespace lamina::render
