// Input: one queue for the window's events and the injected ones, applied at the start of a
// frame. Dear ImGui is fed from the same state, so a panel sees the pointer the app sees and
// Input::ui_wants_mouse means the same for a script as for a hand on the mouse.
#include <imgui.h>

#include <algorithm>
#include <chrono>
#include <cstddef>

#include "lamina/render/viewer.h"
#include "viewer_state.h"

namespace lamina::render {

void inject(const InputEvent& event) {
  viewer_state("inject").queue.push_back(event);
}

const Input& input() {
  return viewer_state("input").input;
}

// The queue is trickled, as Dear ImGui trickles its own: a frame applies the events up to and
// including a button change, and a release that follows a move waits for the next frame. The
// gestures read the input once a frame, so a slow frame (a sanitizer's, a loaded machine's: a
// second and more) that saw a press, the whole drag and the release at once would take the
// press at the drag's end (no drag at all) or a release with the Shift let go after it.
void apply_input_events(ViewerState& s) {
  Input& in = s.input;
  in.pressed = {};
  in.released = {};
  in.wheel = 0.0;
  in.keys.clear();
  size_t applied = 0;
  bool moved = false;
  for (; applied < s.queue.size(); ++applied) {
    const InputEvent& e = s.queue[applied];
    if (e.kind == InputEvent::Kind::kButton) {
      const size_t b = static_cast<size_t>(e.button);
      if (!e.down && moved && b < in.buttons.size() && in.buttons[b]) break;
    }
    switch (e.kind) {
      case InputEvent::Kind::kMouseMove:
        moved = moved || e.mouse_px != in.mouse_px;
        in.mouse_px = e.mouse_px;
        break;
      case InputEvent::Kind::kButton: {
        const size_t b = static_cast<size_t>(e.button);
        if (b >= in.buttons.size()) break;
        const bool changed = e.down != in.buttons[b];
        if (e.down && !in.buttons[b]) in.pressed[b] = true;
        if (!e.down && in.buttons[b]) in.released[b] = true;
        in.buttons[b] = e.down;
        if (changed) {
          ++applied;  // the rest of the queue is the next frame's
          s.queue.erase(s.queue.begin(), s.queue.begin() + static_cast<std::ptrdiff_t>(applied));
          return;
        }
        break;
      }
      case InputEvent::Kind::kWheel:
        in.wheel += e.wheel;
        break;
      case InputEvent::Kind::kKey:
        if (e.key == "shift")
          in.shift = e.down;
        else if (e.key == "ctrl")
          in.ctrl = e.down;
        else if (e.key == "alt")
          in.alt = e.down;
        else if (e.down)
          in.keys.push_back(e.key);
        break;
    }
  }
  s.queue.erase(s.queue.begin(), s.queue.begin() + static_cast<std::ptrdiff_t>(applied));
}

void feed_ui_input(ViewerState& s) {
  ImGuiIO& io = ImGui::GetIO();
  const Eigen::Vector2i size = s.backend->window_size();
  io.DisplaySize = ImVec2(static_cast<float>(size.x()), static_cast<float>(size.y()));
  const double now =
      std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  io.DeltaTime = s.last_frame_time_s > 0.0
                     ? static_cast<float>(std::max(now - s.last_frame_time_s, 1e-4))
                     : 1.0f / 60.0f;
  s.last_frame_time_s = now;
  const Input& in = s.input;
  io.MousePos = ImVec2(static_cast<float>(in.mouse_px.x()), static_cast<float>(in.mouse_px.y()));
  // A click shorter than a frame reaches the panels as held one frame (the release is trickled).
  for (size_t b = 0; b < in.buttons.size(); ++b) io.MouseDown[b] = in.buttons[b];
  io.MouseWheel = static_cast<float>(in.wheel);
  io.KeyShift = in.shift;
  io.KeyCtrl = in.ctrl;
  io.KeyAlt = in.alt;
}

}  // namespace lamina::render
