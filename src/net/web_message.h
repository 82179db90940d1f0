#pragma once
// A page's message (docs/web.md "Messages from the page"), read with checks: a message that
// lacks a field or holds something else is malformed, and its client is dropped. Shared by the
// one-organ session and the world's.
#include <fmt/format.h>

#include <Eigen/Core>
#include <algorithm>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "lamina/core/error.h"

namespace lamina::net::web {

/// The message as JSON with a string "type"; throws lamina::Error (kInvalidInput) otherwise.
inline nlohmann::json parse_message(const std::string& text) {
  nlohmann::json m;
  try {
    m = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception&) {
    throw invalid_input("message", "not JSON");
  }
  if (!m.is_object() || !m.contains("type") || !m["type"].is_string())
    throw invalid_input("message", "not an object with a \"type\"");
  return m;
}

/// Field `key`, a number in [lo, hi].
inline double number(const nlohmann::json& m, const char* key, double lo, double hi) {
  const auto it = m.find(key);
  if (it == m.end() || !it->is_number())
    throw invalid_input("message", std::string("'") + key + "' is missing or not a number");
  const double v = it->get<double>();
  if (!(v >= lo && v <= hi))
    throw invalid_input("message", fmt::format("'{}' is {}, outside [{}, {}]", key, v, lo, hi));
  return v;
}

/// Field `key`, three finite numbers each within `bound` in size.
inline Eigen::Vector3d vector3(const nlohmann::json& m, const char* key, double bound) {
  const auto it = m.find(key);
  if (it == m.end() || !it->is_array() || it->size() != 3 ||
      !std::all_of(it->begin(), it->end(), [](const nlohmann::json& v) { return v.is_number(); }))
    throw invalid_input("message", std::string("'") + key + "' is not three numbers");
  Eigen::Vector3d v((*it)[0].get<double>(), (*it)[1].get<double>(), (*it)[2].get<double>());
  if (!v.allFinite() || v.cwiseAbs().maxCoeff() > bound)
    throw invalid_input("message", fmt::format("'{}' is not finite or beyond {} mm", key, bound));
  return v;
}

/// A "hand" message: a controller's tip (mm, the model's or the world's frame), its trigger and
/// grip in [0, 1] (pressed from 0.5), and the page's count of its poses.
struct HandMessage {
  int hand = 0;  ///< 0 or 1
  uint32_t pose = 0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  bool trigger = false, grip = false;
};

/// A "hand" message's fields, checked (a malformed one drops its client).
inline HandMessage read_hand(const nlohmann::json& m) {
  HandMessage h;
  h.hand = static_cast<int>(number(m, "hand", 0, 1));
  h.pose = static_cast<uint32_t>(number(m, "pose", 0, 4294967295.0));
  h.position = vector3(m, "position", 1e5);
  h.trigger = number(m, "trigger", 0, 1) >= 0.5;
  h.grip = number(m, "grip", 0, 1) >= 0.5;
  return h;
}

inline double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace lamina::net::web
