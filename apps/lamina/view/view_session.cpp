// The session's life and its frame: the simulation thread is started and fed here, and once a
// frame (inside the engine's frame_tick) the latest state is taken, input turned into forces and
// camera moves, panels built, and what to show handed to the engine.
#include "view_session.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstdio>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/render/frame.h"
#include "view_session_state.h"

namespace lamina::cli {

ViewSession::ViewSession(ViewOptions options, ViewModel model) : state_(std::make_unique<State>()) {
  State& v = *state_;
  if (!options.script.empty()) v.script = ScriptPlayer(load_view_script(options.script));
  v.material = options.material;
  if (v.material.volume_stiffness_kpa > 0.0) v.last_volume_kpa = v.material.volume_stiffness_kpa;
  v.solver = options.solver;
  v.routing = options.routing;
  v.rate_hz = options.rate_hz;
  v.auto_rate = options.auto_rate && options.rate_hz > 0.0;
  v.options = std::move(options);
  v.vm = std::make_unique<ViewModel>(std::move(model));
}

ViewSession::~ViewSession() {
  State& v = *state_;
  if (v.loop) v.loop->stop();
  if (v.rebuild_thread.joinable()) v.rebuild_thread.join();
  if (v.started && render::is_initialized()) render::set_callback({});
}

bool ViewSession::script_drives_mouse() const {
  return state_->script.drives_mouse();
}

const world::LoopSnapshot& ViewSession::snapshot() const {
  return state_->snap;
}

const Model& ViewSession::model() const {
  return state_->vm->model;
}

const std::string& ViewSession::last_press() const {
  return state_->last_press;
}

nlohmann::json ViewSession::report() const {
  return state_->report();
}

void ViewSession::start() {
  State& v = *state_;
  if (!render::is_initialized())
    throw Error(ErrorKind::kInternal, "ViewSession::start() before render::init()");
  render::register_model(kModelName, v.vm->model);
  v.style = render::default_style(v.vm->model);  // a translucent skin over its structures
  v.inner_choice = static_cast<int>(v.style.inner);
  v.frame_organ(v.vm->model);  // in the part of the window the left panel leaves free
  v.start_loop();
  v.start_time = Clock::now();
  v.started = true;
  render::set_callback([&v] { v.on_frame(); });
}

bool ViewSession::frame() {
  State& v = *state_;
  const auto frame_start = Clock::now();
  v.act_on_script(v.seconds());
  const bool open = render::frame_tick();
  if (!v.window_shot.empty()) {
    v.save_window_screenshot(v.window_shot);
    v.window_shot.clear();
  }
  ++v.frames;
  v.frame_seconds += std::chrono::duration<double>(Clock::now() - frame_start).count();
  return open && !v.quit;
}

void ViewSession::finish() {
  State& v = *state_;
  if (!v.started) return;
  v.loop->stop();
  v.loop->latest(v.snap);
  v.watch_real_time_and_drag(v.seconds());  // the last window counts in the report too
  v.watch_instability();
  v.write_report();
  render::set_callback({});
  v.started = false;
  // Said in the window while it happened; said again here, where a log keeps it.
  if (v.behind_seen)
    fmt::print(stderr,
               "lamina view: the simulation fell behind real time (down to {:.2f}x); lower the "
               "rate or the model size, or close other programs\n",
               v.min_real_time_factor);
  if (v.unstable_events > 0)
    fmt::print(stderr,
               "lamina view: the simulation became unstable {} time(s), first at t = {:.3f} s: "
               "{}\n",
               v.unstable_events, v.first_unstable_s, sim::describe(v.first_unstable));
}

int ViewSession::run() {
  State& v = *state_;
  start();
  for (;;) {
    const auto frame_start = Clock::now();
    if (!frame()) break;
    // At most 60 frames a second even where the display has no vertical sync (Xvfb): the
    // simulation thread needs the other core more than the screen needs more frames. When the
    // simulation falls behind real time anyway (software GL drawing on the cores the physics
    // needs), the screen gives way: down to 15 frames a second until the loop keeps up again.
    v.frame_interval_us = v.snap.keeping_up ? std::max(16667, v.frame_interval_us * 9 / 10)
                                            : std::min(66667, v.frame_interval_us * 5 / 4);
    std::this_thread::sleep_until(frame_start + std::chrono::microseconds(v.frame_interval_us));
  }
  finish();
  // Never silently wrong: a session in which the simulation blew up ends as `lamina run` would.
  return v.unstable_events > 0 ? static_cast<int>(ErrorKind::kUnstable) : 0;
}

void ViewSession::State::start_loop() {
  routing.locality = std::min(routing.locality, vm->model.rings.locality);
  // The loop's own copy of the model: the viewer replaces vm->model with a cut one, and an undo
  // goes back to the model the loop was made with.
  auto own = std::make_shared<const Model>(vm->model);
  sim::Simulation s = sim::make_simulation(*own, material, solver);
  sim::fix_nodes(s, vm->fixed);
  sim::support_nodes(s, vm->support.nodes, vm->support.stiffness_n_per_m);
  fixed_at.clear();
  support_at.clear();
  for (const int32_t n : vm->fixed) fixed_at.push_back(vm->model.X.row(n).transpose());
  for (size_t k = 0; k < vm->support.nodes.size(); ++k)
    support_at.emplace_back(vm->model.X.row(vm->support.nodes[k]).transpose(),
                            vm->support.stiffness_n_per_m[k]);
  world::LoopOptions lo;
  lo.rate_hz = rate_hz;
  lo.threads = 1;  // the window draws on the other core (llvmpipe renders on the CPU)
  loop = std::make_unique<world::OrganLoop>(std::move(own), std::move(s), routing, lo);
  pinned.clear();
  for (const auto& [node, force] : vm->pinned) pinned.push_back({node, force});
  sent = pinned;
  loop->set_forces(pinned);
  loop->set_paused(paused);
  scene_grasp = vm->grasper.has_value();
  scene_grasp_since_s = -1.0;
  snap = {};
  loop->latest(snap);
  shown_generation = ~uint64_t{0};
  loop->start();
  watched = vm->watched_node >= 0 ? vm->watched_node : (pinned.empty() ? 0 : pinned[0].node);
  rebuild_layers = vm->model.layer_count();
  rebuild_vertices = vm->model.layers.empty() ? 0 : vm->model.layers[0].node_count;
}

void ViewSession::State::push_parameters() {
  try {
    loop->set_parameters(material, solver, routing);
    loop->set_rate(rate_hz);
    param_error.clear();
  } catch (const Error& e) {
    param_error = e.what();
  }
}

void ViewSession::State::update_forces() {
  std::vector<interact::LiveForce> now = pinned;
  if (gesture == Gesture::kDrag && drag_force.norm() > 0.0) now.push_back({drag_node, drag_force});
  const bool same = now.size() == sent.size() &&
                    std::equal(now.begin(), now.end(), sent.begin(), [](auto& a, auto& b) {
                      return a.node == b.node && a.force_mn == b.force_mn;
                    });
  if (same) return;
  sent = now;
  try {
    // On the model this session shows: a cut or an undo the loop took in since is refused here
    // (its nodes are numbered anew), and adopt_cut() lets these forces go on the next frame.
    loop->set_forces(now, model_version);
  } catch (const Error& e) {
    log::debug("lamina view: forces of model {} not set: {}", model_version, e.what());
  }
}

// The scene's grasper, once a frame while it plays: closed at its point, then its jaws where
// its pull has them by the simulated time since. A reset opens the jaws; the loop may do that
// before this frame's snapshot shows the clock going back, and a move of open jaws is a close
// where they are now (refused off the skin): either way they close again at the point.
constexpr int kSceneGraspTries = 60;  // frames (about a second) a refused close is retried

void ViewSession::State::play_scene_grasper() {
  if (!scene_grasp || !vm->grasper || gesture == Gesture::kGrasp) return;
  const interact::Tool& g = *vm->grasper;
  const auto close = [&] {
    loop->set_grasper(std::nullopt);  // a close, not a move of what the jaws may hold
    loop->set_grasper(interact::Jaws{.center_mm = g.point_mm, .radius_mm = g.radius_mm});
    scene_grasp_since_s = snap.time_s;
  };
  if (scene_grasp_since_s >= 0.0 && snap.time_s < scene_grasp_since_s) scene_grasp_since_s = -1.0;
  try {
    if (scene_grasp_since_s < 0.0) {
      close();
    } else {
      const double t = snap.time_s - scene_grasp_since_s;
      const double f = g.pull_s > 0.0 ? std::clamp(t / g.pull_s, 0.0, 1.0) : 1.0;
      try {
        loop->set_grasper(
            interact::Jaws{.center_mm = g.point_mm + f * g.pull_mm, .radius_mm = g.radius_mm});
      } catch (const Error&) {
        close();  // opened by a reset the snapshot does not show yet
      }
    }
    grasp_held = true;
    scene_grasp_refusals = 0;
  } catch (const Error& e) {
    // Just after a reset the loop may still show the pulled shape, with nothing at the point:
    // try again for a few frames before saying so.
    scene_grasp_since_s = -1.0;
    if (++scene_grasp_refusals < kSceneGraspTries) return;
    log::warn("{}: the scene's grasper: {}", vm->source, e.what());
    last_press = std::string("the scene's grasper: ") + e.what();
    scene_grasp = false;
  }
}

// The script's events due by t: their input is injected by the player (the engine applies it at
// the start of the coming frame); what is not input is done here.
void ViewSession::State::act_on_script(double t) {
  if (script.held()) {
    if (waiting_for(script.held_for())) return;
    script.resume(t);
  }
  for (const ScriptEvent& e : script.play(t, render::window_size())) {
    if (!e.mode.empty()) {
      tool_mode = e.mode == "tool";
      grasp_mode = e.mode == "grasp";
      scalpel_mode = e.mode == "scalpel";
    }
    if (!e.screenshot.empty()) save_screenshot(e.screenshot);
    if (!e.window_screenshot.empty()) window_shot = e.window_screenshot;
    if (e.rebuild_layers > 0) {
      rebuild_layers = e.rebuild_layers;
      rebuild_vertices = e.rebuild_skin_vertices;
      start_rebuild();
    }
    // Held at once, and judged from the next frame on: the input played with it (a release
    // just before a "settled") reaches the gestures only in this frame's tick.
    if (!e.wait.empty()) {
      script.hold(t, e);
      wait_from_sim_s = snap.time_s;
    }
    if (e.quit) quit = true;
  }
}

// Whether what a script's "wait" names is still under way.
bool ViewSession::State::waiting_for(const std::string& what) {
  if (what == "rebuild") return rebuild_pending();
  // "resected": X's cut is in, the resected part gone and the remnant in use (held two minutes
  // at most: a resection that failed says so in the panel and the report, and the script goes on).
  if (what == "resected")
    return seconds() - script.held_since() < 120.0 &&
           (!plan.resected || plan.awaiting_cut || rebuild_pending());
  // "simulated": until the simulation's clock has run on that long (a reset or a rebuild that
  // took it back starts the count again); a paused or unstable simulation ends the wait.
  if (what == "simulated") {
    if (paused || unstable_now) return false;
    if (snap.time_s < wait_from_sim_s) wait_from_sim_s = snap.time_s;
    return snap.time_s < wait_from_sim_s + script.hold_event().wait_simulated_s;
  }
  // "settled": a release whose 3-second record is not yet taken.
  return released_at_sim_s >= 0.0 && settle_3s_mm < 0.0;
}

// Once a frame, inside the engine's frame_tick(): the simulation's latest state, then the input,
// then the panels, then what the engine draws this frame.
void ViewSession::State::on_frame() {
  const double t = seconds();
  loop->latest(snap);
  max_displacement_mm = std::max(max_displacement_mm, snap.stats.max_displacement_mm);
  watch_real_time_and_drag(t);
  follow_the_machine(t);
  watch_instability();
  record_plots();
  adopt_rebuilt();
  adopt_cut();
  play_scene_grasper();

  const render::Input& in = render::input();
  if (!in.ui_wants_keyboard)
    for (const std::string& key : in.keys) {
      if (key == "s")
        view_shot = true;
      else
        handle_key(key);
    }
  handle_mouse(in);
  panels();
  update_plan();
  show_state();
  if (view_shot) {
    view_shot = false;
    save_screenshot(screenshot_path);
  }
}

// A cut (K) made on the simulation thread, undone (U), or every cut taken back by a reset (R):
// its model is shown from now on, its display skin split along the cut and the wound inside. Node
// indices change, so the pinned forces are let go (the loop carried them over, but this session
// names nodes by the old model); the structures it crossed are marked where they were cut.
void ViewSession::State::adopt_cut() {
  if (snap.model_version == model_version) {
    if (!snap.cut_error.empty() && cut_message == "cutting...") cut_message = snap.cut_error;
    return;
  }
  if (!snap.model) return;
  model_version = snap.model_version;
  vm->model = *snap.model;
  render::register_model(kModelName, vm->model);  // keeps its style
  shown_generation = ~uint64_t{0};
  pinned.clear();
  update_forces();
  watched = last_drag_node = drag_peak_node = -1;
  if (snap.cuts < cuts) {  // an undo (U) or a reset (R): the marks of the cuts taken back go
    for (; cuts > snap.cuts && !crossed_before.empty(); --cuts) {
      crossed.resize(crossed_before.back());
      crossed_before.pop_back();
    }
    cuts = snap.cuts;
    cut_message = reset_asked && cuts == 0
                      ? std::string("reset: the organ is whole again, its cuts taken back")
                      : fmt::format("undid the last cut ({} in force)", cuts);
    reset_asked = false;
    log::info("lamina view: {}", cut_message);
    return;
  }
  cuts = snap.cuts;
  crossed_before.push_back(crossed.size());
  if (plan.awaiting_cut) take_away_resected();
  const model::CutReport& r = snap.last_cut;
  std::string pieces;
  for (const model::CutPiece& p : r.pieces)
    pieces += fmt::format("{}{:.1f} mL", pieces.empty() ? "" : ", ", p.volume_mm3 / 1000.0);
  cut_message =
      fmt::format("cut {} tetrahedra; {} piece(s): {}", r.cut_tets, r.pieces.size(), pieces);
  for (const model::StructureCut& c : r.structures_cut) {
    crossed.push_back(c);
    cut_message += fmt::format("; {} cut across, {:.1f} mm wide", c.name, c.diameter_mm);
  }
  log::info("lamina view: {}", cut_message);
}

void ViewSession::State::show_state() {
  const bool have_x = snap.x.rows() == vm->model.node_count();
  // Only a new publication is sent: a paused or resting organ costs the engine no upload.
  if (have_x && snap.generation != shown_generation) {
    render::update_positions(kModelName, snap.x);
    shown_generation = snap.generation;
  }
  render::set_style(kModelName, style);
  render::Frame f;
  f.model = &vm->model;
  f.x = have_x ? &snap.x : nullptr;
  for (const interact::LiveForce& lf : sent) {
    render::add_force_arrow(f, lf.node, lf.force_mn, arrow_mm_per_n);
    if (show_rings && routing.routing == interact::Routing::kPaper)
      f.rings.push_back({lf.node, routing.locality});
  }
  for (int32_t node : snap.contact_nodes) render::add_contact_marker(f, node);
  for (int32_t node : snap.grasped_nodes) render::add_contact_marker(f, node);
  if (tip.active) f.markers.push_back({tip.center_mm, tip.radius_mm, {0.7f, 0.75f, 0.8f, 1.0f}});
  // Each vessel the scalpel cut across, where it was cut: the bleeding cue.
  for (const model::StructureCut& c : crossed)
    f.markers.push_back(
        {c.position_mm, std::max(1.5, 0.5 * c.diameter_mm), {0.9f, 0.1f, 0.1f, 1.0f}});
  // The blade's path while it is traced.
  for (const Eigen::Vector3d& p : scalpel.path)
    f.markers.push_back({p, 0.8, {0.95f, 0.95f, 0.95f, 1.0f}});
  render::set_overlays(kModelName, {std::move(f.rings), std::move(f.arrows), std::move(f.markers)});
}

}  // namespace lamina::cli
