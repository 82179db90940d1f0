#pragma once
/// \file
/// `lamina view` of a world scene (several organs, their contact and attachments: docs/world.md)
/// on the viewer engine: the world steps in its own thread (world::WorldLoop) at the wall
/// clock's pace while the scene's graspers and blades play; every body is drawn in its colour,
/// the attachments' ties as beads between them. The mouse pushes or pulls any body (force = gain
/// x drag, Shift pins it), and in dissection mode (X) a drag across the tissue between two organs
/// divides the ties it passes. Keys: R reset (the scene plays again), Space pause, C release
/// the forces, X dissection mode, S screenshot. Runs the same on a window, EGL and the mock
/// backend (tests), driven by the same scripted input as the one-organ viewer (view_script.h).

#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "lamina/io/world_scene.h"
#include "lamina/world/world_loop.h"

namespace lamina::cli {

struct WorldViewOptions {
  double rate_hz = 1000.0;  ///< steps per wall second; 0 = as fast as possible
  /// Start at rate_hz and step at the highest rate the machine keeps (interact::next_rate()).
  bool auto_rate = false;
  double gain_n_per_mm = 0.01;  ///< drag force per mm of drag
  /// G: the grasper's jaws take the skin within this distance, or a mean skin edge and a half of
  /// the body pressed if longer.
  double grasp_radius_mm = 4.0;
  std::string script;  ///< scripted input (docs/viewer.md); empty: none
  std::string report;  ///< JSON report written when the session ends; empty: none
};

class WorldViewSession {
 public:
  /// Takes over the ready world; reads the script. Touches neither the engine nor any thread.
  WorldViewSession(WorldViewOptions options, io::WorldScene scene,
                   std::unique_ptr<io::ReadyWorld> world);
  ~WorldViewSession();
  WorldViewSession(const WorldViewSession&) = delete;
  WorldViewSession& operator=(const WorldViewSession&) = delete;

  bool script_drives_mouse() const;
  /// Registers every body with the engine (render::init() first), starts the world's thread.
  void start();
  /// The script's events due by now, then one engine frame. @return false once closed or quit
  bool frame();
  /// Stops the world, writes the report, says on stderr if it fell behind or blew up.
  void finish();
  /// start(), frame() at up to 60 a second (15 while the world cannot keep up), finish().
  /// @return 0, or ErrorKind::kUnstable's code when a body became unstable
  int run();

  nlohmann::json report() const;
  const world::WorldSnapshot& snapshot() const;
  const std::string& last_press() const;
  /// The panel's last message (a refused command, a saved picture), or empty.
  const std::string& status() const;

  struct State;  ///< world_view_state.h

 private:
  std::unique_ptr<State> state_;
};

}  // namespace lamina::cli
