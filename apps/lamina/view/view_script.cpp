#include "view_script.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "lamina/core/error.h"
#include "lamina/render/viewer.h"
#include "view_session.h"

namespace lamina::cli {
namespace {

using nlohmann::json;

int button_index(const json& v, const std::string& where) {
  if (v == "left") return 0;
  if (v == "right") return 1;
  if (v == "middle") return 2;
  throw invalid_input(where, "expected \"left\", \"right\" or \"middle\"");
}

}  // namespace

std::vector<ScriptEvent> load_view_script(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw invalid_input(path, "cannot read the viewer script");
  std::stringstream text;
  text << in.rdbuf();
  json doc;
  try {
    doc = json::parse(text.str(), nullptr, true, /*ignore_comments=*/true);
  } catch (const json::parse_error& e) {
    throw invalid_input(path, std::string("not valid JSON: ") + e.what());
  }
  if (!doc.is_object() || !doc.contains("events") || !doc["events"].is_array())
    throw invalid_input(path, "expected an object with an \"events\" array");
  std::vector<ScriptEvent> events;
  const json& list = doc["events"];
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string where = path + ": events[" + std::to_string(i) + "]";
    const json& e = list[i];
    if (!e.is_object()) throw invalid_input(where, "expected an object");
    ScriptEvent ev;
    if (!e.contains("at") || !e["at"].is_number() || !(e["at"].get<double>() >= 0.0))
      throw invalid_input(where + ".at", "expected a time in seconds >= 0");
    ev.at_s = e["at"].get<double>();
    for (const auto& [key, value] : e.items()) {
      const std::string at = where + "." + key;
      if (key == "at") {
      } else if (key == "mouse") {
        if (!value.is_array() || value.size() != 2 || !value[0].is_number() ||
            !value[1].is_number())
          throw invalid_input(at, "expected [x, y], fractions of the window (0..1)");
        const Eigen::Vector2d p(value[0].get<double>(), value[1].get<double>());
        if (!(p.minCoeff() >= 0.0 && p.maxCoeff() <= 1.0))
          throw invalid_input(at, "x and y must be in 0..1 (fractions of the window)");
        ev.mouse = p;
      } else if (key == "over") {
        if (!value.is_number() || !(value.get<double>() >= 0.0))
          throw invalid_input(at, "expected seconds >= 0");
        ev.over_s = value.get<double>();
      } else if (key == "press") {
        ev.press = button_index(value, at);
      } else if (key == "release") {
        ev.release = button_index(value, at);
      } else if (key == "shift") {
        if (!value.is_boolean()) throw invalid_input(at, "expected true or false");
        ev.shift = value.get<bool>();
      } else if (key == "scroll") {
        if (!value.is_number() || !std::isfinite(value.get<double>()))
          throw invalid_input(at, "expected a number of wheel clicks");
        ev.scroll = value.get<double>();
      } else if (key == "mode") {
        if (value != "drag" && value != "tool" && value != "grasp" && value != "scalpel" &&
            value != "dissect")
          throw invalid_input(at,
                              "expected \"drag\", \"tool\", \"grasp\", \"scalpel\" or "
                              "\"dissect\" (a world scene's)");
        ev.mode = value.get<std::string>();
      } else if (key == "key") {
        if (value != "r" && value != "space" && value != "c" && value != "t" && value != "g" &&
            value != "d" && value != "k" && value != "u" && value != "p" && value != "x")
          throw invalid_input(at,
                              "expected \"r\", \"space\", \"c\", \"t\", \"g\", \"k\", \"u\", "
                              "\"d\", \"p\" or \"x\"");
        ev.key = value.get<std::string>();
      } else if (key == "screenshot") {
        if (!value.is_string() || value.get<std::string>().empty())
          throw invalid_input(at, "expected a PNG path");
        ev.screenshot = value.get<std::string>();
      } else if (key == "window_screenshot") {
        if (!value.is_string() || value.get<std::string>().empty())
          throw invalid_input(at, "expected a PNG path");
        ev.window_screenshot = value.get<std::string>();
      } else if (key == "rebuild") {
        if (!value.is_object() || !value.contains("layers") ||
            !value["layers"].is_number_integer() || !value.contains("skin_vertices") ||
            !value["skin_vertices"].is_number_integer())
          throw invalid_input(at, "expected {\"layers\": S, \"skin_vertices\": N}");
        ev.rebuild_layers = value["layers"].get<int>();
        ev.rebuild_skin_vertices = value["skin_vertices"].get<int>();
        if (ev.rebuild_layers < 1 || ev.rebuild_layers > 16 || ev.rebuild_skin_vertices < 50)
          throw invalid_input(at, "layers must be 1..16 and skin_vertices >= 50");
      } else if (key == "wait") {
        if (value.is_object() && value.size() == 1 && value.contains("simulated_s") &&
            value["simulated_s"].is_number() && value["simulated_s"].get<double>() > 0.0 &&
            value["simulated_s"].get<double>() <= 3600.0) {
          ev.wait = "simulated";
          ev.wait_simulated_s = value["simulated_s"].get<double>();
        } else if (value == "rebuild" || value == "settled" || value == "resected") {
          ev.wait = value.get<std::string>();
        } else {
          throw invalid_input(at,
                              "expected \"rebuild\", \"settled\", \"resected\" or "
                              "{\"simulated_s\": S} (0 < S <= 3600)");
        }
      } else if (key == "quit") {
        if (!value.is_boolean()) throw invalid_input(at, "expected true");
        ev.quit = value.get<bool>();
      } else {
        throw invalid_input(
            at,
            "unknown key (known: at, mouse, over, press, release, shift, "
            "scroll, mode, key, screenshot, window_screenshot, rebuild, wait, quit)");
      }
    }
    events.push_back(ev);
  }
  std::stable_sort(events.begin(), events.end(),
                   [](const ScriptEvent& a, const ScriptEvent& b) { return a.at_s < b.at_s; });
  return events;
}

void check_view_script(const std::string& path) {
  load_view_script(path);
}

ScriptPlayer::ScriptPlayer(std::vector<ScriptEvent> events) : events_(std::move(events)) {
  for (const ScriptEvent& e : events_)
    drives_mouse_ |= e.mouse || e.press >= 0 || e.release >= 0 || e.shift || e.scroll != 0.0;
}

void ScriptPlayer::hold(double t, const ScriptEvent& e) {
  if (held()) return;
  held_since_s_ = t;
  held_for_ = e;
}

void ScriptPlayer::resume(double t) {
  if (!held()) return;
  held_s_ += t - held_since_s_;
  held_since_s_ = -1.0;
  held_for_ = {};
}

std::vector<ScriptEvent> ScriptPlayer::play(double wall_t, const Eigen::Vector2i& window) {
  using render::InputEvent;
  using render::MouseButton;
  if (held()) return {};
  const double t = wall_t - held_s_;  // the script's own clock
  const Eigen::Vector2d size = window.cast<double>();
  // A glide's mouse where the script's clock says it is now.
  const auto glide = [&] {
    const double f =
        glide_->over_s > 0.0 ? std::clamp((t - glide_->at_s) / glide_->over_s, 0.0, 1.0) : 1.0;
    pos_ = glide_from_ + f * (glide_->mouse->cwiseProduct(size) - glide_from_);
    render::inject(InputEvent::move_to(pos_));
    if (f >= 1.0) glide_.reset();
  };
  if (glide_) glide();
  std::vector<ScriptEvent> due;
  while (next_ < events_.size() && events_[next_].at_s <= t) {
    const ScriptEvent& e = events_[next_++];
    if (e.mouse) {
      if (e.over_s > 0.0) {
        glide_ = e;
        glide_from_ = pos_;
        // Moved as far as the clock is past its start now, not from the next frame on: a wait
        // due in this same frame holds the clock, and the mouse would sit at the glide's start
        // for the whole hold (a slow frame that passed both a drag's glide and its wait left
        // the drag without its pull: View.RebuildSwaps... under ASan, 0.6 mm instead of 4.9).
        glide();
      } else {
        glide_.reset();
        pos_ = e.mouse->cwiseProduct(size);
        render::inject(InputEvent::move_to(pos_));
      }
    }
    if (e.shift)
      render::inject(*e.shift ? InputEvent::key_down("shift") : InputEvent::key_up("shift"));
    if (e.press >= 0) render::inject(InputEvent::press(static_cast<MouseButton>(e.press)));
    if (e.release >= 0) render::inject(InputEvent::release(static_cast<MouseButton>(e.release)));
    if (e.scroll != 0.0) render::inject(InputEvent::scroll(e.scroll));
    if (!e.key.empty()) {
      render::inject(InputEvent::key_down(e.key));
      render::inject(InputEvent::key_up(e.key));
    }
    due.push_back(e);
    if (!e.wait.empty()) break;
  }
  return due;
}

}  // namespace lamina::cli
