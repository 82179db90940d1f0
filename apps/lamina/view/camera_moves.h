#pragma once
// The viewers' camera moves (the one-organ session's and the world's): a left drag that started
// nothing else orbits, a right or middle drag pans, the wheel zooms.
#include <Eigen/Core>
#include <cmath>

#include "lamina/render/camera.h"
#include "lamina/render/viewer.h"

namespace lamina::cli {

/// With nothing else holding the mouse: whether a right or middle press starts a pan; the
/// wheel zooms.
inline bool pan_pressed_and_zoom(const render::Input& in) {
  if (in.wheel != 0.0) render::zoom(render::camera(), std::pow(0.9, in.wheel));
  return in.went_down(render::MouseButton::kRight) || in.went_down(render::MouseButton::kMiddle);
}

/// An orbit's frame (the mouse moved by `delta` pixels). @return whether it goes on
inline bool orbit_frame(const render::Input& in, const Eigen::Vector2d& delta) {
  render::orbit(render::camera(), -0.3 * delta.x(), 0.3 * delta.y());
  return in.down(render::MouseButton::kLeft);
}

/// A pan's frame. @return whether it goes on
inline bool pan_frame(const render::Input& in, const Eigen::Vector2d& delta) {
  render::pan(render::camera(), render::window_size().y(), delta.x(), delta.y());
  return in.down(render::MouseButton::kRight) || in.down(render::MouseButton::kMiddle);
}

}  // namespace lamina::cli
