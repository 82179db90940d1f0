// The world view session's life and frame (world_view.h): the world's thread started and fed,
// and once a frame the latest snapshot taken, the script played, keys and mouse turned into
// forces, strokes and camera moves. The panel, the drawing and the report: world_view_panel.cpp.
#include "world_view.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <thread>

#include "camera_moves.h"
#include "lamina/core/atomic_file.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/interact/rate_choice.h"
#include "lamina/render/camera.h"
#include "lamina/world/pick_body.h"
#include "world_view_state.h"

namespace lamina::cli {

WorldViewSession::WorldViewSession(WorldViewOptions options, io::WorldScene scene,
                                   std::unique_ptr<io::ReadyWorld> world)
    : state_(std::make_unique<State>()) {
  State& v = *state_;
  if (!options.script.empty()) v.script = ScriptPlayer(load_view_script(options.script));
  v.rate_hz = options.rate_hz;
  v.auto_rate = options.auto_rate && options.rate_hz > 0.0;
  v.options = std::move(options);
  v.scene = std::move(scene);
  v.ready = std::move(world);
}

WorldViewSession::~WorldViewSession() {
  State& v = *state_;
  if (v.loop) v.loop->stop();
  if (v.started && render::is_initialized()) render::set_callback({});
}

bool WorldViewSession::script_drives_mouse() const {
  return state_->script.drives_mouse();
}

const world::WorldSnapshot& WorldViewSession::snapshot() const {
  return state_->snap;
}

const std::string& WorldViewSession::last_press() const {
  return state_->last_press;
}

const std::string& WorldViewSession::status() const {
  return state_->status;
}

nlohmann::json WorldViewSession::report() const {
  return state_->report();
}

void WorldViewSession::start() {
  State& v = *state_;
  if (!render::is_initialized())
    throw Error(ErrorKind::kInternal, "WorldViewSession::start() before render::init()");
  // The window draws on the other core (llvmpipe renders on the CPU): one thread steps.
  v.loop = std::make_unique<world::WorldLoop>(
      std::move(v.ready->world),
      world::WorldLoopOptions{
          .rate_hz = v.rate_hz, .threads = 1, .dissections = v.scene.dissections});
  v.loop->latest(v.snap);
  for (size_t b = 0; b < v.snap.bodies.size(); ++b) {
    const world::BodyView& body = v.snap.bodies[b];
    render::register_model(body.name, *body.model);
    render::Style style = render::default_style(*body.model);
    const model::Rgb8 c = model::organ_color(body.name, b);
    style.organ_color = Eigen::Vector3f(c[0], c[1], c[2]) / 255.0f;
    render::set_style(body.name, style);
  }
  // From below and in front: organs meet on their undersides (the gallbladder in its bed, the
  // kidney behind the right lobe), which the one-organ view's from-above angle hides.
  render::camera().elevation_deg = -35.0;
  v.sent.assign(v.snap.bodies.size(), {});
  for (const world::BodyView& b : v.snap.bodies) v.seen_topology.push_back(b.topology);
  v.max_displacement_mm.assign(v.snap.bodies.size(), 0.0);
  v.max_penetration_mm.assign(v.snap.bodies.size(), 0.0);
  v.start_time = Clock::now();
  v.loop->start();
  v.started = true;
  render::set_callback([&v] { v.on_frame(); });
}

bool WorldViewSession::frame() {
  State& v = *state_;
  v.act_on_script(v.seconds());
  const bool open = render::frame_tick();
  if (!v.window_shot.empty()) {
    v.save_screenshot(v.window_shot, true);
    v.window_shot.clear();
  }
  ++v.frames;
  return open && !v.quit;
}

void WorldViewSession::finish() {
  State& v = *state_;
  if (!v.started) return;
  v.loop->stop();
  v.loop->latest(v.snap);
  v.watch(v.seconds());
  if (!v.options.report.empty()) {
    const nlohmann::json r = v.report();
    write_file_atomically(v.options.report, [&](std::ostream& f) { f << r.dump(2) << "\n"; });
  }
  render::set_callback({});
  v.started = false;
  if (v.behind_seen)
    fmt::print(stderr,
               "lamina view: the world fell behind real time (down to {:.2f}x); lower the rate "
               "(--rate) or the bodies' sizes, or close other programs\n",
               v.min_real_time_factor);
  if (v.unstable_events > 0)
    fmt::print(stderr, "lamina view: the world became unstable {} time(s), first {}\n",
               v.unstable_events, v.first_unstable);
}

int WorldViewSession::run() {
  State& v = *state_;
  start();
  for (;;) {
    const auto frame_start = Clock::now();
    if (!frame()) break;
    // As the one-organ viewer: at most 60 frames a second, down to 15 while the world cannot
    // keep up (software GL draws on the cores the physics needs).
    v.frame_interval_us = v.snap.rate.keeping_up ? std::max(16667, v.frame_interval_us * 9 / 10)
                                                 : std::min(66667, v.frame_interval_us * 5 / 4);
    std::this_thread::sleep_until(frame_start + std::chrono::microseconds(v.frame_interval_us));
  }
  finish();
  return v.unstable_events > 0 ? static_cast<int>(ErrorKind::kUnstable) : 0;
}

void WorldViewSession::State::act_on_script(double t) {
  if (script.held()) {
    // Any wait is for the world to settle: every body at rest (the world's own judgement), a
    // minute at most.
    if (!snap.converged && t - script.held_since() < 60.0) return;
    if (!snap.converged) status = "the world did not come to rest within a minute";
    script.resume(t);
  }
  for (const ScriptEvent& e : script.play(t, render::window_size())) {
    if (!e.mode.empty()) {
      dissect_mode = e.mode == "dissect";
      scalpel_mode = e.mode == "scalpel";
      grasp_mode = e.mode == "grasp";
    }
    if (!e.screenshot.empty()) save_screenshot(e.screenshot, false);
    if (!e.window_screenshot.empty()) window_shot = e.window_screenshot;
    if (!e.wait.empty()) script.hold(t, e);
    if (e.quit) quit = true;
  }
}

void WorldViewSession::State::on_frame() {
  const double t = seconds();
  loop->latest(snap);
  forget_renumbered();
  watch(t);
  // As the one-organ viewer: judged after 2 s (the first second holds the solvers' start).
  if (auto_rate && !paused && t >= 2.0)
    if (const auto next = interact::rate_to_follow(rate_hz, snap.rate, "--rate")) {
      rate_hz = *next;
      loop->set_rate(rate_hz);
    }
  const render::Input& in = render::input();
  if (!in.ui_wants_keyboard)
    for (const std::string& key : in.keys) handle_key(key);
  handle_mouse(in);
  panel();
  show();
}

void WorldViewSession::State::handle_key(const std::string& key) {
  if (key == "r") {
    loop->reset();  // opens the grasper too
    unstable_seen = false;
    grasp_held = false;
  } else if (key == "space") {
    paused = !paused;
    loop->set_paused(paused);
  } else if (key == "c") {
    pinned.clear();
    drag.reset();
    loop->clear_forces();
    sent.assign(sent.size(), {});
    if (grasp_held) loop->set_grasper(std::nullopt);
    grasp_held = false;
  } else if (key == "x") {
    dissect_mode = !dissect_mode;
    scalpel_mode = grasp_mode = false;
  } else if (key == "k") {
    scalpel_mode = !scalpel_mode;
    dissect_mode = grasp_mode = false;
  } else if (key == "g") {
    grasp_mode = !grasp_mode;
    dissect_mode = scalpel_mode = false;
  } else if (key == "u") {
    loop->undo_cut();  // the snapshot's cut_message says when there is none
  } else if (key == "s") {
    save_screenshot("", false);
  }
}

void WorldViewSession::State::start_left_gesture(const render::Input& in) {
  const Eigen::Vector2i size = render::window_size();
  const render::Camera& camera = render::camera();
  press_pos = in.mouse_px;
  const render::Ray ray =
      render::pixel_ray(camera, size.x(), size.y(), in.mouse_px.x(), in.mouse_px.y());
  const auto [b, hit] = world::pick_body(snap, ray.origin, ray.direction);
  const std::string where =
      fmt::format("press at ({:.0f}, {:.0f})", in.mouse_px.x(), in.mouse_px.y());
  if (dissect_mode || scalpel_mode) {
    gesture = scalpel_mode ? Gesture::kScalpel : Gesture::kDissect;
    stroke.begin(ray, b >= 0 ? hit.distance_mm : (camera.target - ray.origin).norm());
    const char* what = scalpel_mode ? ": scalpel" : ": dissection";
    last_press = where + what + (b >= 0 ? " on " + snap.bodies[b].name : std::string());
  } else if (b >= 0 && grasp_mode) {
    start_grasp(snap.bodies[static_cast<size_t>(b)], hit.node, where);
  } else if (b >= 0) {
    const world::BodyView& body = snap.bodies[static_cast<size_t>(b)];
    gesture = Gesture::kDrag;
    drag = Force{body.id, body.topology, {.node = hit.node}};
    grab_point = body.x.row(hit.node).transpose();
    ++drags;
    last_press = fmt::format("{}: drag {} node {}", where, body.name, hit.node);
  } else {
    gesture = Gesture::kOrbit;
    last_press = where + ": missed every body: orbit";
  }
  log::debug("lamina view: {}", last_press);
}

// The jaws take at least a mean skin edge and a half around their centre: on a real organ's
// skin at paper size (edges of 5-8 mm) 4 mm held one node, a spike pulled with 4.8 N.
static double jaws_radius(const Model& m, double at_least_mm) {
  const Eigen::MatrixX3i& F = m.layers[0].F;
  double sum = 0.0;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) sum += (m.X.row(F(f, k)) - m.X.row(F(f, (k + 1) % 3))).norm();
  return F.rows() > 0 ? std::max(at_least_mm, 1.5 * sum / (3.0 * static_cast<double>(F.rows())))
                      : at_least_mm;
}

// The jaws close on the picked node and the skin around it; the drag moves them. A grasp still
// holding (Shift-released) opens first: jaws given while closed would carry it to the new point.
void WorldViewSession::State::start_grasp(const world::BodyView& body, int32_t node,
                                          const std::string& where) {
  if (grasp_held) loop->set_grasper(std::nullopt);
  grasp_held = false;
  grab_point = body.x.row(node).transpose();
  grasp_radius_mm = jaws_radius(*body.model, options.grasp_radius_mm);
  try {
    loop->set_grasper(interact::Jaws{.center_mm = grab_point, .radius_mm = grasp_radius_mm});
  } catch (const Error& e) {
    last_press = where + ": " + e.what();
    return;
  }
  gesture = Gesture::kGrasp;
  ++grasps;
  last_press = fmt::format("{}: grasp {} node {}", where, body.name, node);
}

void WorldViewSession::State::handle_mouse(const render::Input& in) {
  const Eigen::Vector2i size = render::window_size();
  render::Camera& camera = render::camera();
  const Eigen::Vector2d delta = in.mouse_px - last_pos;
  last_pos = in.mouse_px;
  if (gesture == Gesture::kNone && !in.ui_wants_mouse) {
    if (in.went_down(render::MouseButton::kLeft))
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
      // The paper's drag: force = gain x drag in the plane facing the eye at the grabbed point.
      const Eigen::Vector2d d = in.mouse_px - press_pos;
      drag->force.force_mn = 1000.0 * options.gain_n_per_mm *
                             render::drag_in_view_plane(camera, size.y(), grab_point, d.x(), d.y());
      if (!left_down) {
        if (in.shift && drag->force.force_mn.norm() > 0.0) pinned.push_back(*drag);
        drag.reset();
        gesture = Gesture::kNone;
      }
      send_forces();
      break;
    }
    case Gesture::kGrasp: {
      // Retraction: the jaws follow the mouse in the plane facing the eye at the grasp point.
      const Eigen::Vector2d d = in.mouse_px - press_pos;
      try {
        loop->set_grasper(interact::Jaws{
            .center_mm =
                grab_point + render::drag_in_view_plane(camera, size.y(), grab_point, d.x(), d.y()),
            .radius_mm = grasp_radius_mm});
      } catch (const Error& e) {  // a reset opened the jaws, and no skin is under them now
        last_press = std::string("grasp: ") + e.what();
        gesture = Gesture::kNone;
        break;
      }
      if (!left_down) {
        gesture = Gesture::kNone;
        grasp_held = in.shift;  // Shift+release keeps holding, as it pins a drag
        if (!grasp_held) loop->set_grasper(std::nullopt);
      }
      break;
    }
    case Gesture::kDissect:
    case Gesture::kScalpel: {
      const render::Ray ray =
          render::pixel_ray(camera, size.x(), size.y(), in.mouse_px.x(), in.mouse_px.y());
      const auto [b, hit] = world::pick_body(snap, ray.origin, ray.direction);
      stroke.extend(ray, b >= 0 ? hit.distance_mm : -1.0);
      if (!left_down) {
        const bool cuts = gesture == Gesture::kScalpel;
        gesture = Gesture::kNone;
        if (cuts)
          cut_along_stroke();
        else
          dissect_along_stroke();
      }
      break;
    }
    case Gesture::kNone:
      break;
  }
}

// A body renumbered since the last frame (cut, or put back uncut by a reset or an undo): drawn
// with its new skin. A cut carried its forces to their nodes' first copies: the drag and pins on
// it follow them there. Put back, the loop let them go: the drag and pins on it are dropped too.
void WorldViewSession::State::forget_renumbered() {
  for (size_t b = 0; b < snap.bodies.size() && b < seen_topology.size(); ++b) {
    const world::BodyView& body = snap.bodies[b];
    if (body.topology == seen_topology[b]) continue;
    seen_topology[b] = body.topology;
    render::register_model(body.name, *body.model);  // its new skin; the style is kept
    std::map<int32_t, int32_t> now;                  // a sent force's node: its node now
    if (const auto carried = world::carried_force_nodes(body, sent[b])) {
      for (size_t k = 0; k < carried->size(); ++k) now[sent[b][k].node] = (*carried)[k];
      for (size_t k = 0; k < carried->size(); ++k) sent[b][k].node = (*carried)[k];
    } else {  // released; or other forces than the view sent (one it set meanwhile): let them go
      sent[b].clear();
      try {
        if (!body.force_nodes.empty()) loop->set_forces(body.id, body.topology, {});
      } catch (const Error&) {  // renumbered again since: its forces went with it
      }
    }
    const auto follows = [&](Force& f) {  // false: its force went
      const auto it = now.find(f.force.node);
      if (it == now.end()) return false;
      f.force.node = it->second;
      f.topology = body.topology;
      return true;
    };
    std::erase_if(pinned, [&](Force& f) { return f.body == body.id && !follows(f); });
    if (drag && drag->body == body.id && !follows(*drag)) {
      drag.reset();
      if (gesture == Gesture::kDrag) gesture = Gesture::kNone;
    }
  }
}

// Every body's forces (its pinned ones and the drag on it), sent where they changed.
void WorldViewSession::State::send_forces() {
  for (size_t b = 0; b < snap.bodies.size(); ++b) {
    const world::BodyView& body = snap.bodies[b];
    std::vector<interact::LiveForce> forces;
    for (const Force& f : pinned)
      if (f.body == body.id) forces.push_back(f.force);
    if (drag && drag->body == body.id && drag->force.force_mn.norm() > 0.0)
      forces.push_back(drag->force);
    const bool same = forces.size() == sent[b].size() &&
                      std::equal(forces.begin(), forces.end(), sent[b].begin(),
                                 [](const interact::LiveForce& x, const interact::LiveForce& y) {
                                   return x.node == y.node && x.force_mn == y.force_mn;
                                 });
    if (same) continue;
    try {
      loop->set_forces(body.id, body.topology, forces);
      sent[b] = std::move(forces);
    } catch (const Error& e) {
      // A cut taken since this frame's snapshot carried the forces; the next frame follows it.
      // Anything else is said, and the drag ends.
      const auto live = loop->bodies();
      const bool cut_since = std::any_of(live.begin(), live.end(), [&](const auto& h) {
        return h.first == body.id && h.second != body.topology;
      });
      if (cut_since) continue;
      status = e.what();
      drag.reset();
    }
  }
}

// The release of a dissection drag: the blade's upper end 3 mm above the traced path, reaching
// 30 mm along the view direction, dividing the ties within 3 mm of it.
void WorldViewSession::State::dissect_along_stroke() {
  if (stroke.path.size() < 2) {
    status = "the dissection's drag was too short";
    return;
  }
  try {
    loop->dissect(stroke.blade_top(), stroke.direction, 30.0 + TracedStroke::kAboveMm, 3.0);
    ++strokes;
  } catch (const Error& e) {
    status = e.what();
  }
  stroke.path.clear();
}

// The release of a scalpel drag: as the one-organ viewer's (the blade's upper end 3 mm above the
// traced path, reaching scalpel_depth_mm into the tissue), through every body it passes and the
// ties between them. A body cut is renumbered: a drag or pinned force on it is let go.
void WorldViewSession::State::cut_along_stroke() {
  if (stroke.path.size() < 2) {
    status = "the scalpel's drag was too short";
    return;
  }
  try {
    loop->cut(stroke.blade_top(), stroke.direction, scalpel_depth_mm + TracedStroke::kAboveMm);
    ++scalpel_strokes;
  } catch (const Error& e) {
    status = e.what();
  }
  stroke.path.clear();
}

void WorldViewSession::State::watch(double t) {
  for (size_t b = 0; b < snap.bodies.size() && b < max_displacement_mm.size(); ++b) {
    const world::BodyStepStats& s = snap.bodies[b].stats;
    max_displacement_mm[b] = std::max(max_displacement_mm[b], s.sim.max_displacement_mm);
    max_penetration_mm[b] = std::max(max_penetration_mm[b], s.max_penetration_mm);
  }
  if (t > 1.5 && snap.rate.measured_rate_hz > 0.0 && !snap.paused) {
    min_real_time_factor = std::min(min_real_time_factor, snap.rate.real_time_factor);
    behind_seen = behind_seen || !snap.rate.keeping_up;
  }
  if (snap.step_us > 0.0) {
    contact_share_sum += snap.profile.contact_us / snap.step_us;
    ++contact_share_frames;
  }
  if (snap.unstable != sim::Instability::kNone && !unstable_seen) {
    unstable_seen = true;
    if (unstable_events++ == 0)
      first_unstable = fmt::format("in body '{}' at t = {:.3f} s: {}", snap.unstable_body,
                                   snap.time_s, sim::describe(snap.unstable));
    log::error("lamina view: the world became unstable {}; press R to reset", first_unstable);
  }
}

}  // namespace lamina::cli
