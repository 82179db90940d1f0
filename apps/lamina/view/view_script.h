#pragma once
// Scripted viewer input (docs/viewer.md): timed mouse, key and screenshot events read from JSON,
// injected into the viewer engine as the window's own events would be, so that they take the
// same path through the session's gesture code as a real mouse.

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

namespace lamina::cli {

struct ScriptEvent {
  double at_s = 0.0;                     ///< wall seconds after the window opened
  std::optional<Eigen::Vector2d> mouse;  ///< where the pointer goes, as fractions of the window
  double over_s = 0.0;                   ///< glide there over this long (0 = jump)
  int press = -1, release = -1;          ///< button: 0 left, 1 right, 2 middle
  std::optional<bool> shift;             ///< Shift held from now on
  double scroll = 0.0;                   ///< wheel clicks (> 0 away from the user)
  std::string mode;               ///< "drag", "tool", "grasp", "scalpel"; "dissect" (a world scene)
  std::string key;                ///< "r" reset, "space" pause, "c" release pinned, "t"
  std::string screenshot;         ///< PNG path: the 3-D view, without the panels
  std::string window_screenshot;  ///< PNG path: the whole window, panels included
  int rebuild_layers = 0;         ///< > 0: rebuild the model with this many layers...
  int rebuild_skin_vertices = 0;  ///< ...and about this many skin vertices
  /// Hold the script's clock here until something that takes this machine's own time is done:
  /// "rebuild" (the model a rebuild before this event asked for is in use) or "settled" (3
  /// simulated seconds have passed since the last drag's release, and the report measured it)
  /// or "resected" (X's resection is done: cut, the resected part taken away, the remnant in
  /// use; two minutes at most) or "simulated" (wait_simulated_s simulated seconds have passed
  /// since the hold began: a drag held that long dents the organ alike on a fast and on a
  /// sanitized machine).
  std::string wait;
  double wait_simulated_s = 0.0;
  bool quit = false;
};

/// Reads and checks a script. Events are returned sorted by time.
/// \note Throws lamina::Error (kInvalidInput) "PATH: events[i].key: problem".
std::vector<ScriptEvent> load_view_script(const std::string& path);

/// Replays a script against a clock: at each frame, the input of the events now due (and of a
/// mouse glide in progress, interpolated) is injected into the engine (render::inject), and the
/// events are returned for what is not input (mode, screenshots, rebuild, quit).
class ScriptPlayer {
 public:
  explicit ScriptPlayer(std::vector<ScriptEvent> events);
  /// The script moves the mouse, presses buttons, holds Shift or turns the wheel.
  bool drives_mouse() const { return drives_mouse_; }
  /// @param[in] t_s     seconds since the session started
  /// @param[in] window  the window's size, pixels (positions are fractions of it)
  /// @return the events due by t_s, in order; a wait event ends the list (nothing after it is
  ///         played in the same call, so the caller can hold() the clock first)
  std::vector<ScriptEvent> play(double t_s, const Eigen::Vector2i& window);
  /// Holds the script's clock from t_s for what wait event `e` names: play() returns nothing
  /// until resume(); the events after the hold keep their spacing, shifted by how long it lasted.
  void hold(double t_s, const ScriptEvent& e);
  void resume(double t_s);
  bool held() const { return held_since_s_ >= 0.0; }
  const std::string& held_for() const { return held_for_.wait; }  ///< the wait being held for
  /// The wait event being held for (its wait_simulated_s), and the wall time its hold began.
  const ScriptEvent& hold_event() const { return held_for_; }
  double held_since() const { return held_since_s_; }

 private:
  std::vector<ScriptEvent> events_;
  size_t next_ = 0;
  bool drives_mouse_ = false;
  double held_since_s_ = -1.0, held_s_ = 0.0;  // a hold in progress; all holds so far
  ScriptEvent held_for_;                       // the wait event of the hold in progress
  std::optional<ScriptEvent> glide_;           // a mouse glide in progress
  Eigen::Vector2d glide_from_ = Eigen::Vector2d::Zero();
  Eigen::Vector2d pos_ = Eigen::Vector2d::Zero();  // where the script put the pointer, pixels
};

}  // namespace lamina::cli
