#pragma once
// Internal (not installed): how the scene reader (scene_read.cpp) describes and reads a scene
// file's keys. Each object of a scene - the top level, "model", "material", a tool, ... - is one
// table of Key rows, and that table drives both the reading (rows in order, each key the object
// has read by its row) and the warning about keys the object should not have (any key no row
// names). So a key is written once: adding a row is all it takes to accept a new key.

#include <fmt/format.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "io/scene_names.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/io/scene.h"

namespace lamina::io::detail {

using nlohmann::json;

// The file gives tool forces in newtons; the simulation works in mN (kg mm / s^2).
inline constexpr double kMilliNewtonsPerNewton = 1000.0;

// Every check of one document goes through this reader, so every message has the same shape:
// "SOURCE: key.path: problem".
class Reader {
 public:
  explicit Reader(const std::string& source) : source_(source) {}

  [[noreturn]] void fail(const std::string& path, const std::string& problem) const {
    throw invalid_input(source_, path + ": " + problem);
  }

  // Warns about keys no row of `keys` names (a typo must not pass silently, but an extra key
  // such as a comment field must not stop a run either).
  template <class Keys>
  void warn_unknown(const json& object, const std::string& path, const Keys& keys) const {
    for (const auto& item : object.items()) {
      const std::string& key = item.key();
      if (std::any_of(std::begin(keys), std::end(keys),
                      [&](const auto& row) { return row.name == key; }))
        continue;
      log::warn("{}: {}: unknown key, ignored", source_, join(path, key));
    }
  }

  static std::string join(const std::string& path, std::string_view key) {
    return path.empty() ? std::string(key) : path + "." + std::string(key);
  }

  void require_object(const json& v, const std::string& path) const {
    if (!v.is_object()) fail(path, "expected an object {...}, got " + describe(v));
  }

  double number(const json& v, const std::string& path) const {
    if (!v.is_number()) fail(path, "expected a number, got " + describe(v));
    const double d = v.get<double>();
    if (!std::isfinite(d)) fail(path, "must be finite, got " + describe(v));
    return d;
  }

  // Integers may be written 100000 or 1e5, but not 2.5.
  int64_t integer(const json& v, const std::string& path, int64_t lo, int64_t hi) const {
    int64_t i = 0;
    if (v.is_number_unsigned()) {  // nlohmann stores non-negative integers as unsigned
      const uint64_t u = v.get<uint64_t>();
      if (u > static_cast<uint64_t>(hi)) fail(path, range_text(lo, hi) + ", got " + v.dump());
      i = static_cast<int64_t>(u);
    } else if (v.is_number_integer()) {
      i = v.get<int64_t>();
    } else if (v.is_number_float()) {
      const double d = v.get<double>();
      if (!std::isfinite(d) || d != std::floor(d) || std::abs(d) > 9e15)
        fail(path, "expected an integer, got " + describe(v));
      i = static_cast<int64_t>(d);
    } else {
      fail(path, "expected an integer, got " + describe(v));
    }
    if (i < lo || i > hi) fail(path, range_text(lo, hi) + ", got " + std::to_string(i));
    return i;
  }

  bool boolean(const json& v, const std::string& path) const {
    if (!v.is_boolean()) fail(path, "expected true or false, got " + describe(v));
    return v.get<bool>();
  }

  std::string string(const json& v, const std::string& path) const {
    if (!v.is_string()) fail(path, "expected a string, got " + describe(v));
    const std::string s = v.get<std::string>();
    if (s.empty()) fail(path, "must not be empty");
    return s;
  }

  Eigen::Vector3d vec3(const json& v, const std::string& path) const {
    if (!v.is_array() || v.size() != 3 ||
        !std::all_of(v.begin(), v.end(), [](const json& e) { return e.is_number(); }))
      fail(path, "expected an array of 3 numbers, got " + describe(v));
    Eigen::Vector3d out;
    for (int c = 0; c < 3; ++c) out[c] = number(v[static_cast<size_t>(c)], path);
    return out;
  }

  // Short, one-line rendering of a value for messages.
  static std::string describe(const json& v) {
    std::string kind;
    switch (v.type()) {
      case json::value_t::null:
        return "null";
      case json::value_t::boolean:
        kind = "boolean ";
        break;
      case json::value_t::string:
        kind = "string ";
        break;
      case json::value_t::array:
        kind = "array ";
        break;
      case json::value_t::object:
        kind = "object ";
        break;
      default:
        break;
    }
    std::string text = v.dump();
    if (text.size() > 40) text = text.substr(0, 37) + "...";
    return kind + text;
  }

 private:
  static std::string range_text(int64_t lo, int64_t hi) {
    // An upper bound that only guards the integer type is not worth showing.
    if (hi >= std::numeric_limits<int32_t>::max()) return "must be >= " + std::to_string(lo);
    return "must be between " + std::to_string(lo) + " and " + std::to_string(hi);
  }

  const std::string& source_;
};

struct Value;

// An object of the file being read: "material", "tools[1]", "" for the top level.
struct Object {
  const Reader& r;
  const json& data;
  const std::string& path;

  bool has(std::string_view key) const { return data.contains(key); }
  std::string path_of(std::string_view key) const { return Reader::join(path, key); }
  [[noreturn]] void fail(std::string_view key, const std::string& problem) const {
    r.fail(path_of(key), problem);
  }
  // The value of `key`, which the object has: for a row that reads a neighbour with its own.
  Value value(std::string_view key) const;
};

// One key's value, found in `in`, with the reader's checks: each names `path` when it fails.
struct Value {
  const Object& in;
  const json& data;
  std::string path;  // "material.young_modulus_kpa"

  [[noreturn]] void fail(const std::string& problem) const { in.r.fail(path, problem); }
  double number() const { return in.r.number(data, path); }
  // A number `ok` accepts; `rule` says what it wants ("must be > 0"), the message adds the value.
  template <class Ok>
  double number(Ok ok, std::string_view rule) const {
    const double v = number();
    if (!ok(v)) fail(fmt::format("{}, got {}", rule, v));
    return v;
  }
  int64_t integer(int64_t lo, int64_t hi) const { return in.r.integer(data, path, lo, hi); }
  bool boolean() const { return in.r.boolean(data, path); }
  std::string string() const { return in.r.string(data, path); }
  Eigen::Vector3d vec3() const { return in.r.vec3(data, path); }
  // One of `names`' spellings, or a message listing them all: expected "a", "b" or "c".
  template <class Enum, size_t N>
  Enum choice(const Spelling<Enum> (&names)[N]) const {
    const std::string v = string();
    std::string expected;
    for (size_t k = 0; k < N; ++k) {
      if (v == names[k].first) return names[k].second;
      expected += k == 0 ? "" : k + 1 == N ? " or " : ", ";
      expected += "\"" + std::string(names[k].first) + "\"";
    }
    fail("expected " + expected + ", got \"" + v + "\"");
  }
};

inline Value Object::value(std::string_view key) const {
  return {*this, data.at(key), path_of(key)};
}

// One row of an object's table: a key and how it is read into `Target` (the scene, or the tool
// or region being built).
template <class Target>
struct Key {
  std::string_view name;
  // Reads the key's value into the target. Called in table order, for the keys the object has;
  // empty for a key another row reads (a tool's gain_n_per_mm, with its drag_mm).
  std::function<void(const Value&, Target&)> read;
  // A rule across keys, checked at this row's turn (before `read`) whether or not the key is
  // there. Rules sit where the reader always checked them, so a scene with several mistakes is
  // still told of the same one first.
  std::function<void(const Object&, Target&)> before = {};
};

template <class Target>
using Keys = std::vector<Key<Target>>;

// Reads the keys of `object` that `keys` names, in the table's order.
template <class Target>
void read_keys(const Object& object, const Keys<Target>& keys, Target& target) {
  for (const Key<Target>& key : keys) {
    if (key.before) key.before(object, target);
    const auto it = object.data.find(key.name);
    if (it == object.data.end() || !key.read) continue;
    key.read({object, *it, object.path_of(key.name)}, target);
  }
}

// `data` at `path` as an object of the file: checked to be one, and its keys that no row of
// `keys` names warned about.
template <class Target>
Object open_object(const Reader& r, const json& data, const std::string& path,
                   const Keys<Target>& keys) {
  r.require_object(data, path);
  r.warn_unknown(data, path, keys);
  return {r, data, path};
}

// An object with no rule across its keys: opened, then its keys read.
template <class Target>
void read_object(const Reader& r, const json& data, const std::string& path,
                 const Keys<Target>& keys, Target& target) {
  read_keys(open_object(r, data, path, keys), keys, target);
}

// ---- Readers for the rows of plain keys. `field` picks what a row fills in its target: a
// member pointer (&interact::Tool::start_s) or at<...> for a nested one.

// A member of a member: at<&Scene::solver, &sim::SolverOptions::dt_s> is scene.solver.dt_s.
template <auto Outer, auto Inner>
inline constexpr auto at = [](auto& object) -> auto& {
  return object.*Outer.*Inner;
};

// A number that `ok` accepts; `rule` is the message's "must be > 0 N/mm".
template <class Field, class Ok>
auto number(Field field, Ok ok, const char* rule) {
  return [=](const Value& v, auto& target) { std::invoke(field, target) = v.number(ok, rule); };
}

// An integer in [lo, hi].
template <class Field>
auto integer(Field field, int64_t lo, int64_t hi) {
  return [=](const Value& v, auto& target) {
    auto& out = std::invoke(field, target);
    out = static_cast<std::remove_reference_t<decltype(out)>>(v.integer(lo, hi));
  };
}

template <class Field>
auto boolean(Field field) {
  return [=](const Value& v, auto& target) { std::invoke(field, target) = v.boolean(); };
}

// Three numbers.
template <class Field>
auto vec3(Field field) {
  return [=](const Value& v, auto& target) { std::invoke(field, target) = v.vec3(); };
}

// One of an enum's spellings (scene_names.h).
template <class Field, class Enum, size_t N>
auto choice(Field field, const Spelling<Enum> (&names)[N]) {
  return
      [=, &names](const Value& v, auto& target) { std::invoke(field, target) = v.choice(names); };
}

// `read`, and the scene notes that the file gave the key (flag: &Scene::integrator_given).
template <class Read>
auto given(bool Scene::*flag, Read read) {
  return [=](const Value& v, Scene& s) {
    s.*flag = true;
    read(v, s);
  };
}

inline bool positive(double v) {
  return v > 0.0;
}
inline bool non_negative(double v) {
  return v >= 0.0;
}
inline bool fraction(double v) {
  return v >= 0.0 && v <= 1.0;
}

}  // namespace lamina::io::detail
