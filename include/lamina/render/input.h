#pragma once
/// \file
/// The viewer's input, as the app sees it once a frame (render::input()) and as it is fed to the
/// engine. Real events (the GLFW window's mouse and keys) and injected ones (a script, a test, the
/// mock backend) are the same InputEvent and go through the same queue, so that whatever drives
/// the viewer, the app's gesture code sees one kind of input.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace lamina::render {

enum class MouseButton : uint8_t { kLeft = 0, kRight = 1, kMiddle = 2 };

/// One input event: a pointer move, a button or key going down or up, wheel clicks.
struct InputEvent {
  enum class Kind : uint8_t { kMouseMove, kButton, kWheel, kKey };
  Kind kind = Kind::kMouseMove;
  Eigen::Vector2d mouse_px = Eigen::Vector2d::Zero();  ///< kMouseMove: window pixels, top left
  MouseButton button = MouseButton::kLeft;             ///< kButton
  bool down = true;                                    ///< kButton, kKey: pressed or released
  double wheel = 0.0;                                  ///< kWheel: clicks, > 0 away from the user
  /// kKey: "a".."z", "0".."9", "space", "escape", "enter", or a modifier: "shift", "ctrl", "alt".
  std::string key;

  static InputEvent move_to(const Eigen::Vector2d& px) {
    InputEvent e;
    e.mouse_px = px;
    return e;
  }
  static InputEvent press(MouseButton b) { return button_event(b, true); }
  static InputEvent release(MouseButton b) { return button_event(b, false); }
  static InputEvent scroll(double clicks) {
    InputEvent e;
    e.kind = Kind::kWheel;
    e.wheel = clicks;
    return e;
  }
  static InputEvent key_down(std::string name) { return key_event(std::move(name), true); }
  static InputEvent key_up(std::string name) { return key_event(std::move(name), false); }

 private:
  static InputEvent button_event(MouseButton b, bool down) {
    InputEvent e;
    e.kind = Kind::kButton;
    e.button = b;
    e.down = down;
    return e;
  }
  static InputEvent key_event(std::string name, bool down) {
    InputEvent e;
    e.kind = Kind::kKey;
    e.down = down;
    e.key = std::move(name);
    return e;
  }
};

/// The input of one frame: the state after the events that arrived since the previous frame,
/// and what those events changed. Valid from the start of frame_tick() to the next one. The
/// events are trickled: a frame takes them up to and including one button change, and a release
/// after a move waits a frame, so that each press and release is seen where it happened.
struct Input {
  Eigen::Vector2d mouse_px = Eigen::Vector2d::Zero();  ///< window pixels from the top left
  std::array<bool, 3> buttons{};                       ///< held now, by MouseButton
  std::array<bool, 3> pressed{};                       ///< went down this frame
  std::array<bool, 3> released{};                      ///< went up this frame
  bool shift = false, ctrl = false, alt = false;
  double wheel = 0.0;             ///< clicks this frame, > 0 away from the user
  std::vector<std::string> keys;  ///< keys pressed this frame (not modifiers), in order
  /// Dear ImGui wants the mouse (the pointer is over a panel, or a panel holds a click): the app
  /// should not act on the mouse this frame.
  bool ui_wants_mouse = false;
  bool ui_wants_keyboard = false;  ///< a text field has the keyboard

  bool down(MouseButton b) const { return buttons[static_cast<size_t>(b)]; }
  bool went_down(MouseButton b) const { return pressed[static_cast<size_t>(b)]; }
};

}  // namespace lamina::render
