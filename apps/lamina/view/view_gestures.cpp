// Mouse and keys: the reference paper's drag (force = gain x drag, measured in the plane facing
// the eye at the grabbed node), Shift-pinned forces, the tool tip, and orbit, pan and zoom.
// A left press that does not start a drag says why (last_press(), and the debug log): a viewer
// that silently ignores a press is a flaky test nobody can read.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "camera_moves.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/interact/pick.h"
#include "lamina/render/camera.h"
#include "view_session_state.h"

namespace lamina::cli {
namespace {

const char* gesture_name(Gesture g) {
  switch (g) {
    case Gesture::kOrbit:
      return "an orbit";
    case Gesture::kPan:
      return "a pan";
    case Gesture::kDrag:
      return "a drag";
    case Gesture::kTool:
      return "a tool-tip move";
    case Gesture::kGrasp:
      return "a grasp";
    case Gesture::kScalpel:
      return "a cut";
    case Gesture::kPlane:
      return "a move of the resection plane";
    case Gesture::kNone:
      break;
  }
  return "nothing";
}

}  // namespace

void ViewSession::State::handle_key(const std::string& key) {
  if (key == "r") {
    loop->reset();  // opens the jaws; the scene's grasper closes again at its start; uncuts
    reset_asked = cuts > 0;
    grasp_held = false;
    scene_grasp = vm->grasper.has_value();
    scene_grasp_since_s = -1.0;
  } else if (key == "space") {
    paused = !paused;
    loop->set_paused(paused);
  } else if (key == "c") {
    pinned.clear();
    update_forces();
    if (grasp_held) loop->set_grasper(std::nullopt);
    grasp_held = false;
    scene_grasp = false;
  } else if (key == "t") {
    tool_mode = !tool_mode;
    grasp_mode = scalpel_mode = false;
  } else if (key == "g") {
    grasp_mode = !grasp_mode;
    tool_mode = scalpel_mode = false;
  } else if (key == "k") {
    scalpel_mode = !scalpel_mode;
    tool_mode = grasp_mode = false;
  } else if (key == "d") {
    style.display_skin = !style.display_skin;  // the display skin or the simulation's
  } else if (key == "p") {
    toggle_plan();
  } else if (key == "x") {
    resect_plan();
  } else if (key == "u") {
    loop->undo_cut();  // adopt_cut() shows the model it goes back to
    cut_message = snap.undoable > 0 ? "undoing the last cut..." : "no cut to undo";
  }
}

void ViewSession::State::start_left_gesture(const render::Input& in) {
  const Eigen::Vector2i size = render::window_size();
  const render::Camera& camera = render::camera();
  press_pos = in.mouse_px;
  const render::Ray ray =
      render::pixel_ray(camera, size.x(), size.y(), in.mouse_px.x(), in.mouse_px.y());
  interact::SkinHit hit;
  const bool have_x = snap.x.rows() == vm->model.node_count();
  if (have_x) hit = interact::pick_skin(vm->model, snap.x, ray.origin, ray.direction);
  const std::string where = fmt::format("press at ({:.0f}, {:.0f}) of {}x{}", in.mouse_px.x(),
                                        in.mouse_px.y(), size.x(), size.y());
  if (press_on_plane(ray.origin, ray.direction)) {
    // With the resection plane shown, a press on it moves it (Shift turns it).
    gesture = Gesture::kPlane;
    last_press = where + ": the resection plane";
  } else if (scalpel_mode) {
    // The blade's path starts where the press meets the skin (or, off the organ, at the depth
    // of the organ's centre); the blade goes in along the view direction.
    gesture = Gesture::kScalpel;
    scalpel.begin(ray, hit.node >= 0 ? hit.distance_mm : (camera.target - ray.origin).norm());
    last_press = where + (hit.node >= 0 ? ": scalpel on the organ" : ": scalpel beside the organ");
  } else if (grasp_mode && hit.node >= 0) {
    // The jaws close on the picked node and the skin around it; the drag moves them. A grasp
    // still holding (Shift-held, or the scene's) opens first: set_grasper on closed jaws would
    // carry what they hold to the new point.
    if (grasp_held) loop->set_grasper(std::nullopt);
    grasp_held = false;
    scene_grasp = false;
    jaws.center_mm = snap.x.row(hit.node).transpose();
    try {
      loop->set_grasper(jaws);
    } catch (const Error& e) {
      last_press = where + ": " + e.what();
      log::debug("lamina view: {}", last_press);
      return;
    }
    gesture = Gesture::kGrasp;
    grasp_held = false;
    grab_point = jaws.center_mm;
    watched = hit.node;
    last_press = where + ": grasp node " + std::to_string(hit.node);
  } else if (grasp_mode) {
    gesture = Gesture::kOrbit;
    last_press = where + ": grasper mode, missed the organ: orbit";
  } else if (tool_mode) {
    gesture = Gesture::kTool;
    tool_depth_mm =
        hit.node >= 0 ? hit.distance_mm - tip.radius_mm : (camera.target - ray.origin).norm();
    last_press = where + ": tool-tip mode (no drag)";
  } else if (hit.node >= 0) {
    gesture = Gesture::kDrag;
    drag_node = hit.node;
    grab_point = snap.x.row(hit.node).transpose();
    drag_force.setZero();
    watched = hit.node;
    last_drag_node = hit.node;
    drag_peak_mm = 0.0;
    drag_peak_node = -1;
    released_at_sim_s = -1.0;
    settle_3s_mm = -1.0;
    ++drags;
    last_press = where + ": drag node " + std::to_string(hit.node);
  } else {
    gesture = Gesture::kOrbit;
    last_press = where + (have_x ? ": missed the organ: orbit"
                                 : ": no simulation state yet, nothing to pick: orbit");
  }
  log::debug("lamina view: {}", last_press);
}

void ViewSession::State::handle_mouse(const render::Input& in) {
  const Eigen::Vector2i size = render::window_size();
  render::Camera& camera = render::camera();
  const Eigen::Vector2d delta = in.mouse_px - last_pos;
  last_pos = in.mouse_px;
  const bool left = in.went_down(render::MouseButton::kLeft);
  if (left && (gesture != Gesture::kNone || in.ui_wants_mouse)) {
    last_press = fmt::format("press at ({:.0f}, {:.0f}): {}", in.mouse_px.x(), in.mouse_px.y(),
                             gesture != Gesture::kNone
                                 ? std::string(gesture_name(gesture)) + " was in progress"
                                 : "a panel has the mouse (Dear ImGui wants it)");
    log::debug("lamina view: {}", last_press);
  }
  if (gesture == Gesture::kNone && !in.ui_wants_mouse) {
    if (left)
      start_left_gesture(in);
    else if (pan_pressed_and_zoom(in))
      gesture = Gesture::kPan;
  }
  const bool left_down = in.down(render::MouseButton::kLeft);
  switch (gesture) {
    case Gesture::kOrbit:
      if (!orbit_frame(in, delta)) gesture = Gesture::kNone;
      break;
    case Gesture::kPan:
      if (!pan_frame(in, delta)) gesture = Gesture::kNone;
      break;
    case Gesture::kDrag: {
      // The paper's interaction: force = gain x drag, the drag measured in the plane facing
      // the eye at the grabbed point.
      const Eigen::Vector2d d = in.mouse_px - press_pos;
      drag_force = 1000.0 * options.gain_n_per_mm *
                   render::drag_in_view_plane(camera, size.y(), grab_point, d.x(), d.y());
      if (!left_down) {
        if (in.shift && drag_force.norm() > 0.0) pinned.push_back({drag_node, drag_force});
        gesture = Gesture::kNone;
        drag_force.setZero();
        released_at_sim_s = snap.time_s;
      }
      update_forces();
      break;
    }
    case Gesture::kGrasp: {
      // Retraction: the jaws follow the mouse in the plane facing the eye at the grasp point.
      const Eigen::Vector2d d = in.mouse_px - press_pos;
      jaws.center_mm =
          grab_point + render::drag_in_view_plane(camera, size.y(), grab_point, d.x(), d.y());
      loop->set_grasper(jaws);
      if (!left_down) {
        gesture = Gesture::kNone;
        grasp_held = in.shift;  // Shift+release keeps holding, as it pins a drag
        if (!grasp_held) {
          loop->set_grasper(std::nullopt);
          released_at_sim_s = snap.time_s;
        }
      }
      break;
    }
    case Gesture::kTool: {
      tool_depth_mm = std::max(1.0, tool_depth_mm + 2.0 * in.wheel);
      const render::Ray ray =
          render::pixel_ray(camera, size.x(), size.y(), in.mouse_px.x(), in.mouse_px.y());
      tip.center_mm = ray.origin + tool_depth_mm * ray.direction;
      tip.active = left_down;
      loop->set_tool_tip(tip);
      if (!left_down) gesture = Gesture::kNone;
      break;
    }
    case Gesture::kScalpel: {
      const render::Ray ray =
          render::pixel_ray(camera, size.x(), size.y(), in.mouse_px.x(), in.mouse_px.y());
      interact::SkinHit hit;
      if (snap.x.rows() == vm->model.node_count())
        hit = interact::pick_skin(vm->model, snap.x, ray.origin, ray.direction);
      scalpel.extend(ray, hit.node >= 0 ? hit.distance_mm : -1.0);
      if (!left_down) {
        gesture = Gesture::kNone;
        cut_along_path();
      }
      break;
    }
    case Gesture::kPlane:
      move_plane(in.mouse_px - press_pos, in.shift);
      if (!left_down) gesture = Gesture::kNone;
      break;
    case Gesture::kNone:
      break;
  }
}

// The release of a scalpel drag: the blade's upper end 3 mm above the traced path (so that it
// enters through the skin), reaching the panel's depth under it, along the view direction.
void ViewSession::State::cut_along_path() {
  if (scalpel.path.size() < 2) {
    cut_message = "the drag was too short to cut";
    return;
  }
  try {
    loop->cut(scalpel.blade_top(), scalpel.direction, scalpel_depth_mm + TracedStroke::kAboveMm);
    cut_message = "cutting...";
  } catch (const Error& e) {
    cut_message = e.what();
  }
  scalpel.path.clear();
}

}  // namespace lamina::cli
