#pragma once
// Scripted viewer input (docs/viewer.md): timed mouse, key and screenshot events read from JSON,
// replayed through the same code path as the real mouse.

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

namespace lamina::render {

struct ScriptEvent {
  double at_s = 0.0;                     ///< wall seconds after the window opened
  std::optional<Eigen::Vector2d> mouse;  ///< where the pointer goes, as fractions of the window
  double over_s = 0.0;                   ///< glide there over this long (0 = jump)
  int press = -1, release = -1;          ///< button: 0 left, 1 right, 2 middle
  std::optional<bool> shift;             ///< Shift held from now on
  double scroll = 0.0;                   ///< wheel clicks (> 0 away from the user)
  std::string mode;                      ///< "drag" or "tool"
  std::string key;                       ///< "r" reset, "space" pause, "c" release pinned, "t"
  std::string screenshot;                ///< PNG path: the 3-D view, without the panels
  std::string window_screenshot;         ///< PNG path: the whole window, panels included
  int rebuild_layers = 0;                ///< > 0: rebuild the model with this many layers...
  int rebuild_skin_vertices = 0;         ///< ...and about this many skin vertices
  bool quit = false;
};

/// Reads and checks a script. Events are returned sorted by time.
/// \note Throws lamina::Error (kInvalidInput) "PATH: events[i].key: problem".
std::vector<ScriptEvent> load_viewer_script(const std::string& path);

}  // namespace lamina::render
