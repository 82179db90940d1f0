#include "lamina/render/legend.h"

#include <epoxy/gl.h>
// epoxy first: Dear ImGui's OpenGL 3 backend must not load another GL header.
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>

#include <algorithm>

#include "lamina/core/error.h"
#include "lamina/model/embed_surface.h"

namespace lamina::render {

std::vector<LegendEntry> legend_entries(const Frame& frame) {
  std::vector<LegendEntry> out;
  if (!frame.model) return out;
  const Model& m = *frame.model;
  const int32_t skin = lamina::model::display_skin_index(m);
  for (size_t i = 0; i < m.embedded.size(); ++i) {
    if (static_cast<int32_t>(i) == skin) continue;
    const EmbeddedLook look =
        i < frame.style.embedded.size() ? frame.style.embedded[i] : embedded_look(m, i);
    if (look.visible) out.push_back({m.embedded[i].name, look.color});
  }
  if (!out.empty()) out.insert(out.begin(), {"organ", frame.style.organ_color});
  return out;
}

void legend_window(const std::vector<LegendEntry>& entries, bool bottom) {
  if (entries.empty()) return;
  const ImGuiIO& io = ImGui::GetIO();
  const float margin = 0.8f * ImGui::GetFontSize();
  ImGui::SetNextWindowPos(
      ImVec2(io.DisplaySize.x - margin, bottom ? io.DisplaySize.y - margin : margin),
      ImGuiCond_Always, ImVec2(1.0f, bottom ? 1.0f : 0.0f));
  ImGui::SetNextWindowBgAlpha(0.6f);
  ImGui::Begin("Legend", nullptr,
               ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_AlwaysAutoResize |
                   ImGuiWindowFlags_NoSavedSettings | ImGuiWindowFlags_NoFocusOnAppearing |
                   ImGuiWindowFlags_NoNav | ImGuiWindowFlags_NoMove);
  const float swatch = ImGui::GetFontSize();
  for (size_t i = 0; i < entries.size(); ++i) {
    const LegendEntry& e = entries[i];
    ImGui::PushID(static_cast<int>(i));
    ImGui::ColorButton("##swatch", ImVec4(e.color[0], e.color[1], e.color[2], 1.0f),
                       ImGuiColorEditFlags_NoTooltip | ImGuiColorEditFlags_NoPicker |
                           ImGuiColorEditFlags_NoDragDrop,
                       ImVec2(swatch, swatch));
    ImGui::SameLine();
    ImGui::TextUnformatted(e.name.c_str());
    ImGui::PopID();
  }
  ImGui::End();
}

void draw_legend(const std::vector<LegendEntry>& entries, int width, int height) {
  if (entries.empty() || width < 1 || height < 1) return;
  ImGuiContext* const previous = ImGui::GetCurrentContext();
  ImGuiContext* const context = ImGui::CreateContext();
  ImGui::SetCurrentContext(context);
  ImGuiIO& io = ImGui::GetIO();
  io.IniFilename = nullptr;
  io.DisplaySize = ImVec2(static_cast<float>(width), static_cast<float>(height));
  io.DeltaTime = 1.0f / 60.0f;
  ImGui::StyleColorsDark();
  // Dear ImGui's built-in pixel font at a whole multiple of its 13 px, about 2% of the
  // picture's height: crisp, and readable on a 1200 x 900 figure.
  ImFontConfig font;
  font.SizePixels = 13.0f * static_cast<float>(std::clamp(height / 450, 1, 4));
  io.Fonts->AddFontDefault(&font);
  ImGui::GetStyle().ScaleAllSizes(font.SizePixels / 13.0f);
  const bool ready = ImGui_ImplOpenGL3_Init("#version 330 core");
  if (ready) {
    // Two frames: a window that sizes itself to its content is measured in its first frame
    // and shown from its second.
    for (int frame = 0; frame < 2; ++frame) {
      ImGui_ImplOpenGL3_NewFrame();
      ImGui::NewFrame();
      legend_window(entries);
      ImGui::Render();
    }
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    ImGui_ImplOpenGL3_Shutdown();
  }
  ImGui::DestroyContext(context);
  ImGui::SetCurrentContext(previous);
  if (!ready)
    throw Error(ErrorKind::kUnavailable, "Dear ImGui cannot draw the legend with this context");
}

}  // namespace lamina::render
