// What the session leaves behind: the report (docs/viewer.md lists its keys), with its watch over
// real time and over the last drag, the screenshots and the deformed skin.
#include <fmt/format.h>

#include <algorithm>
#include <ostream>

#include "lamina/core/atomic_file.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/interact/rate_choice.h"
#include "lamina/io/mesh_file.h"
#include "lamina/model/embed_surface.h"
#include "lamina/model/summarize_model.h"
#include "view_session_state.h"

namespace lamina::cli {
namespace {

std::string default_screenshot_name() {
  static int n = 0;
  return fmt::format("lamina_view_{:03d}.png", ++n);
}

}  // namespace

// Each time the simulation becomes unstable: counted for the report and the exit code, and
// logged once (the panel says it for as long as it lasts).
void ViewSession::State::watch_instability() {
  const bool unstable = snap.stats.unstable != sim::Instability::kNone;
  if (unstable && !unstable_now) {
    ++unstable_events;
    if (first_unstable == sim::Instability::kNone)
      first_unstable = snap.stats.unstable, first_unstable_s = snap.time_s;
    log::error(
        "lamina view: the simulation became unstable at t = {:.3f} s: {}; it stopped "
        "(press R to reset, then lower the gain, dt or the stiffness)",
        snap.time_s, sim::describe(snap.stats.unstable));
  }
  unstable_now = unstable;
}

// The report's record of real time and of the last drag (see their fields).
void ViewSession::State::watch_real_time_and_drag(double t) {
  if (t > 1.5 && snap.real_time_factor > 0.0 && !paused) {
    min_real_time_factor = min_real_time_factor > 0.0
                               ? std::min(min_real_time_factor, snap.real_time_factor)
                               : snap.real_time_factor;
    behind_seen = behind_seen || !snap.keeping_up;
  }
  if (gesture == Gesture::kDrag && snap.x.rows() == vm->model.node_count()) {
    Eigen::Index node = 0;
    const double peak = (snap.x - vm->model.X).rowwise().norm().maxCoeff(&node);
    if (peak > drag_peak_mm) drag_peak_mm = peak, drag_peak_node = static_cast<int32_t>(node);
  }
  if (released_at_sim_s >= 0.0 && settle_3s_mm < 0.0) {
    if (snap.time_s < released_at_sim_s)
      released_at_sim_s = -1.0;  // reset to time 0 since: nothing to measure
    else if (snap.time_s >= released_at_sim_s + 3.0)
      settle_3s_mm = snap.stats.max_displacement_mm;
  }
}

// Real time by default: the loop's measured second picks the rate (interact::rate_to_follow),
// said in the log and on screen. The first look waits for 2 s: the first second's steps include
// the window's and the solver's start (55 ms a step measured where 7 ms is the rule).
void ViewSession::State::follow_the_machine(double t) {
  if (!auto_rate || paused || rate_hz <= 0.0 || t < 2.0) return;
  const std::optional<double> next =
      interact::rate_to_follow(rate_hz, world::measured_window(snap), "--rate");
  if (!next) return;
  rate_hz = *next;
  loop->set_rate(rate_hz);
}

nlohmann::json ViewSession::State::report() const {
  nlohmann::json j;
  j["frames"] = frames;
  j["rate_hz"] = rate_hz;  // the last one stepped at
  j["auto_rate"] = auto_rate;
  j["mean_frame_ms"] = frames ? 1000.0 * frame_seconds / static_cast<double>(frames) : 0.0;
  j["sim_steps"] = snap.steps;
  j["sim_time_s"] = snap.time_s;
  j["achieved_rate_hz"] = snap.achieved_rate_hz;
  j["dt_s"] = snap.dt_s;
  j["real_time_factor"] = snap.real_time_factor;
  j["min_real_time_factor"] = min_real_time_factor;
  j["fell_behind"] = behind_seen;
  j["cuts"] = cuts;
  j["nodes"] = vm->model.node_count();
  j["structures_cut"] = static_cast<int64_t>(crossed.size());
  j["resection"] = plan_json();
  j["drag_node"] = last_drag_node;
  j["drag_peak_displacement_mm"] = drag_peak_mm;
  j["drag_peak_node"] = drag_peak_node;
  if (drag_peak_node >= 0 && last_drag_node >= 0)
    j["drag_peak_distance_from_drag_mm"] =
        (vm->model.X.row(drag_peak_node) - vm->model.X.row(last_drag_node)).norm();
  j["max_displacement_3s_after_release_mm"] = settle_3s_mm;
  j["max_displacement_mm"] = max_displacement_mm;
  j["final_max_displacement_mm"] = snap.stats.max_displacement_mm;
  j["final_volume_change_pct"] = snap.stats.volume_change_pct;
  j["recoveries"] = snap.recoveries;
  j["unstable_events"] = unstable_events;
  if (unstable_events > 0) {
    j["first_unstable_reason"] = sim::describe(first_unstable);
    j["first_unstable_at_s"] = first_unstable_s;
  }
  j["drags"] = drags;
  j["pinned_forces"] = pinned.size();
  j["nodes"] = vm->model.node_count();
  j["layers"] = vm->model.layer_count();
  // The embedded surfaces drawn at the end (the display skin and the visible structures).
  const Model& m = vm->model;
  const int32_t skin = model::display_skin_index(m);
  j["display_skin"] = skin >= 0 && style.display_skin;
  j["embedded_drawn"] = nlohmann::json::array();
  for (size_t i = 0; i < m.embedded.size(); ++i) {
    const bool drawn = static_cast<int32_t>(i) == skin
                           ? style.display_skin
                           : i >= style.embedded.size() || style.embedded[i].visible;
    if (drawn)
      j["embedded_drawn"].push_back({{"name", m.embedded[i].name},
                                     {"role", std::string(role_name(m.embedded[i].role))},
                                     {"label", m.embedded[i].label},
                                     {"vertices", m.embedded[i].V.rows()},
                                     {"triangles", m.embedded[i].F.rows()}});
  }
  j["rebuilds"] = rebuilds;
  j["screenshots"] = screenshots;
  return j;
}

void ViewSession::State::write_report() const {
  if (options.report.empty()) return;
  const std::string text = report().dump(2);
  write_file_atomically(options.report, [&](std::ostream& out) { out << text << "\n"; });
}

void ViewSession::State::save_screenshot(std::string path) {
  if (path.empty()) path = default_screenshot_name();
  try {
    render::screenshot(path);
    screenshots.push_back(path);
    status = "saved " + path;
  } catch (const Error& e) {
    status = e.what();
  }
}

void ViewSession::State::save_window_screenshot(const std::string& path) {
  try {
    render::screenshot(path, /*with_ui=*/true);
    screenshots.push_back(path);
  } catch (const Error& e) {
    status = e.what();
  }
}

void ViewSession::State::export_skin(const std::string& path) {
  try {
    SurfaceMesh mesh = model::layer_mesh(vm->model, 0);
    mesh.V = snap.x.topRows(vm->model.layers[0].node_count);
    io::write_mesh(mesh, path);
    status = "exported the skin to " + path;
  } catch (const Error& e) {
    status = e.what();
  }
}

}  // namespace lamina::cli
