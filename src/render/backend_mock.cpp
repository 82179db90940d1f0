// The mock backend: no OpenGL, no window. The engine around it still runs everything a frame
// does (input, the callback with its Dear ImGui panels, the upload decisions, the record of what
// was drawn), so that viewer logic is tested with no display: nmwsharp/polyscope's
// openGL_mock backend is the model.
#include <imgui.h>

#include "viewer_state.h"

namespace lamina::render {
namespace {

class MockBackend final : public ViewerBackend {
 public:
  explicit MockBackend(const ViewerOptions& options) : size_(options.width, options.height) {
    // Dear ImGui lays text out with its font atlas even when nothing draws it.
    unsigned char* pixels = nullptr;
    int w = 0, h = 0;
    ImGui::GetIO().Fonts->GetTexDataAsRGBA32(&pixels, &w, &h);
  }

  void poll_events(std::vector<InputEvent>&) override {}
  bool close_requested() override { return false; }
  Eigen::Vector2i window_size() override { return size_; }
  Eigen::Vector2i framebuffer_size() override { return size_; }
  void new_ui_frame() override {}
  void draw(const std::vector<DrawItem>& items, const Camera&, ImDrawData*) override {
    background_ = items.empty() ? Style{}.background : items.front().frame.style.background;
  }
  Image read_display() override { return blank(size_.x(), size_.y()); }
  Image render_view(const std::vector<DrawItem>& items, const Camera&, int width,
                    int height) override {
    background_ = items.empty() ? Style{}.background : items.front().frame.style.background;
    return blank(width, height);
  }
  void present() override {}
  void forget(const std::string&) override {}

 private:
  Image blank(int width, int height) const {
    Image img;
    img.width = width;
    img.height = height;
    img.rgba.resize(static_cast<size_t>(width) * height * 4);
    for (size_t i = 0; i < img.rgba.size(); i += 4)
      for (int c = 0; c < 4; ++c)
        img.rgba[i + c] = static_cast<uint8_t>(255.0f * (c == 3 ? 1.0f : background_[c]) + 0.5f);
    return img;
  }

  Eigen::Vector2i size_;
  Eigen::Vector4f background_ = Style{}.background;
};

}  // namespace

std::unique_ptr<ViewerBackend> make_mock_backend(const ViewerOptions& options) {
  return std::make_unique<MockBackend>(options);
}

}  // namespace lamina::render
