// World scenes (world_scene.h): a "bodies" array of one-organ scenes read by the scene reader
// itself (scene_object.h), so a body's keys, defaults and messages are a scene file's, and the
// world's own keys read with the same tables (scene_keys.h).
#include "lamina/io/world_scene.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "io/scene_keys.h"
#include "io/scene_object.h"
#include "lamina/core/error.h"

namespace lamina::io {
namespace {

using detail::boolean;
using detail::json;
using detail::Keys;
using detail::non_negative;
using detail::number;
using detail::Object;
using detail::open_object;
using detail::positive;
using detail::read_keys;
using detail::read_object;
using detail::Reader;
using detail::Value;

std::string item(const std::string& path, size_t k) {
  return path + "[" + std::to_string(k) + "]";
}

// contact: the world's contact options (world::ContactOptions, docs/world.md).
void read_contact(const Value& v, WorldScene& w) {
  using C = world::ContactOptions;
  static const Keys<C> kKeys = {
      {"enabled", boolean(&C::enabled)},
      {"self_contact", boolean(&C::self_contact)},
      {"reach_mm", number(&C::reach_mm, positive, "must be > 0 mm")},
      {"stiffness_kpa_per_mm", number(&C::stiffness_kpa_per_mm, positive, "must be > 0 kPa/mm")},
      {"margin_mm", number(&C::margin_mm, non_negative, "must be >= 0 mm")},
      {"self_exclusion_mm", number(&C::self_exclusion_mm, non_negative,
                                   "must be >= 0 mm (0: three mean edges, at least reach + 2)")},
      {"rest_overlap_tolerance_mm",
       number(&C::rest_overlap_tolerance_mm, non_negative, "must be >= 0 mm")},
  };
  read_object(v.in.r, v.data, v.path, kKeys, w.contact);
}

// bodies[k]: {"name": ..., then a one-organ scene's keys}; the world's solver and output are
// given to each, so that each is read, defaulted and checked as a scene file is.
void read_bodies(const Value& v, WorldScene& w) {
  if (!v.data.is_array() || v.data.empty())
    v.fail("expected an array of bodies [{\"name\": \"liver\", \"model\": {...}}, ...], got " +
           Reader::describe(v.data));
  const json& top = v.in.data;
  std::set<std::string> names;
  for (size_t k = 0; k < v.data.size(); ++k) {
    const std::string path = item(v.path, k);
    const json& in = v.data[k];
    v.in.r.require_object(in, path);
    if (!in.contains("name")) v.in.r.fail(path, "needs \"name\": the body's name (\"liver\")");
    const std::string name = v.in.r.string(in["name"], path + ".name");
    if (!names.insert(name).second)
      v.in.r.fail(path + ".name", "\"" + name + "\" names another body already");
    for (const char* shared : {"solver", "output"})
      if (in.contains(shared))
        v.in.r.fail(Reader::join(path, shared), "a world's bodies step together: give \"" +
                                                    std::string(shared) +
                                                    "\" once, at the top of the scene");
    json body = in;
    body.erase("name");
    for (const char* shared : {"solver", "output"})
      if (top.contains(shared)) body[shared] = top[shared];
    WorldBodyScene b{.name = name, .scene = detail::read_scene_object(body, w.source, path)};
    // A world's tools are named where they act: no body is poked unless its scene says so.
    if (!in.contains("tools")) b.scene.default_tool = false;
    w.bodies.push_back(std::move(b));
  }
}

// attachments[k]: {"bodies": ["liver", "gallbladder"], "name", "reach_mm",
// "stiffness_kpa_per_mm", "strength_kpa"}.
void read_attachments(const Value& v, WorldScene& w) {
  using A = world::AttachmentDef;
  static const Keys<A> kKeys = {
      {"bodies", {}},  // read below: names against the bodies
      {"name", [](const Value& n, A& a) { a.name = n.string(); }},
      {"reach_mm", number(&A::reach_mm, positive, "must be > 0 mm")},
      {"stiffness_kpa_per_mm", number(&A::stiffness_kpa_per_mm, positive, "must be > 0 kPa/mm")},
      {"strength_kpa", number(&A::strength_kpa, positive, "must be > 0 kPa")},
  };
  if (!v.data.is_array())
    v.fail(
        "expected an array of attachments [{\"bodies\": [\"liver\", \"gallbladder\"]}, ...], "
        "got " +
        Reader::describe(v.data));
  std::string known;
  for (const WorldBodyScene& b : w.bodies) known += (known.empty() ? "" : ", ") + b.name;
  for (size_t k = 0; k < v.data.size(); ++k) {
    const std::string path = item(v.path, k);
    const Object in = open_object(v.in.r, v.data[k], path, kKeys);
    if (!in.has("bodies")) in.r.fail(path, "needs \"bodies\": [\"A\", \"B\"], the two it joins");
    const json& pair = v.data[k]["bodies"];
    if (!pair.is_array() || pair.size() != 2)
      in.fail("bodies", "expected two body names [\"A\", \"B\"], got " + Reader::describe(pair));
    WorldAttachmentScene a;
    std::string ends[2];
    for (size_t e = 0; e < 2; ++e) {
      const std::string end_path = item(path + ".bodies", e);
      ends[e] = in.r.string(pair[e], end_path);
      if (std::none_of(w.bodies.begin(), w.bodies.end(),
                       [&](const WorldBodyScene& b) { return b.name == ends[e]; }))
        in.r.fail(end_path, "no body is named \"" + ends[e] + "\" (the bodies: " + known + ")");
    }
    if (ends[0] == ends[1]) in.fail("bodies", "a body cannot be attached to itself");
    a.body_a = ends[0];
    a.body_b = ends[1];
    read_keys(in, kKeys, a.def);
    w.attachments.push_back(std::move(a));
  }
}

// dissections[k]: a blade (a scalpel's keys) and "reach_mm".
void read_dissections(const Value& v, WorldScene& w) {
  if (!v.data.is_array())
    v.fail("expected an array of blades [{\"path\": [[x, y, z], ...], ...}], got " +
           Reader::describe(v.data));
  for (size_t k = 0; k < v.data.size(); ++k) {
    const std::string path = item(v.path, k);
    v.in.r.require_object(v.data[k], path);
    json blade = v.data[k];
    world::Dissection d;
    if (blade.contains("reach_mm")) {
      d.reach_mm = v.in.r.number(blade["reach_mm"], path + ".reach_mm");
      if (!(d.reach_mm > 0.0))
        v.in.r.fail(path + ".reach_mm", fmt::format("must be > 0 mm, got {}", d.reach_mm));
      blade.erase("reach_mm");
    }
    d.blade = detail::read_blade(v.in.r, blade, path);
    w.dissections.push_back(std::move(d));
  }
}

}  // namespace

bool is_world_scene(const std::string& json_text) {
  const json doc = json::parse(json_text, nullptr, /*allow_exceptions=*/false, true);
  return doc.is_object() && doc.contains("bodies");
}

bool is_world_scene_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) return false;
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::ostringstream text;
  text << in.rdbuf();
  return is_world_scene(text.str());
}

WorldScene parse_world_scene(const std::string& json_text, const std::string& source_name) {
  // Bodies after the solver and output they are given, attachments after the bodies they name.
  static const Keys<WorldScene> kKeys = {
      {"solver", {}},
      {"output", {}},
      {"bodies", read_bodies},
      {"attachments", read_attachments},
      {"contact", read_contact},
      {"dissections", read_dissections},
  };
  WorldScene w;
  w.source = source_name;
  const json doc = detail::parse_scene_json(json_text, source_name);
  if (!doc.is_object())
    throw invalid_input(source_name,
                        "expected a JSON object {...} at the top, got " + Reader::describe(doc));
  const Reader r(w.source);
  r.warn_unknown(doc, "", kKeys);
  if (!doc.contains("bodies"))
    r.fail("bodies", "a world scene needs its bodies [{\"name\": ..., \"model\": ...}, ...]");
  // The shared keys read once as a scene's, so that their mistakes are named where they are.
  json shared = json::object();
  for (const char* key : {"solver", "output"})
    if (doc.contains(key)) shared[key] = doc[key];
  const Scene common = detail::read_scene_object(shared, source_name, "");
  w.solver = common.solver;
  w.output = common.output;
  read_keys(Object{r, doc, ""}, kKeys, w);
  return w;
}

WorldScene load_world_scene(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw invalid_input(path, "is a folder, not a scene file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw invalid_input(path, "cannot open the scene file (does it exist?)");
  std::ostringstream text;
  text << in.rdbuf();
  WorldScene w = parse_world_scene(text.str(), path);
  const fs::path folder = fs::path(path).parent_path();
  auto resolve = [&](std::string& p) {
    if (!p.empty() && fs::path(p).is_relative()) p = (folder / p).lexically_normal().string();
  };
  for (WorldBodyScene& b : w.bodies) {
    if (b.scene.input != kScenePhantom) resolve(b.scene.input);
    resolve(b.scene.model_path);
  }
  return w;
}

std::unique_ptr<ReadyWorld> make_ready_world(const WorldScene& scene,
                                             const ReadVolumeOptions& read_options,
                                             const ProgressFn& progress, bool scalpels_cut) {
  auto ready = std::make_unique<ReadyWorld>();
  ready->world.contact = scene.contact;
  const auto in_body = [&](size_t k, const Error& e) {
    return Error(e.kind(), fmt::format("{}: bodies[{}] ('{}'): {}", scene.source, k,
                                       scene.bodies[k].name, e.what()));
  };
  // Every model first, and the bodies' places checked on them (a probe world of plain
  // simulations), before each is prepared: a refusal comes before the preparations' reports.
  std::vector<SceneModel> models;
  for (size_t k = 0; k < scene.bodies.size(); ++k) {
    const WorldBodyScene& b = scene.bodies[k];
    try {
      const ProgressFn stage = progress ? ProgressFn([&](std::string_view what, double f) {
        progress(fmt::format("{}: {}", b.name, what),
                 (static_cast<double>(k) + f) / static_cast<double>(scene.bodies.size()));
      })
                                        : ProgressFn{};
      models.push_back(make_scene_model(b.scene, read_options, stage));
    } catch (const Error& e) {
      throw in_body(k, e);
    }
  }
  {
    world::World probe;
    probe.contact = scene.contact;
    for (size_t k = 0; k < models.size(); ++k) {
      auto m = std::make_shared<Model>(models[k].model);
      world::BodyDef def{.name = scene.bodies[k].name, .model = m};
      def.simulation = sim::make_simulation(*m);
      try {
        world::create_body(probe, std::move(def));
      } catch (const Error& e) {
        throw Error(e.kind(), scene.source + ": " + e.what());
      }
    }
  }
  for (size_t k = 0; k < scene.bodies.size(); ++k) {
    const WorldBodyScene& b = scene.bodies[k];
    ReadyScene rs;
    try {
      rs = make_ready_scene(b.scene, std::move(models[k]));
    } catch (const Error& e) {
      throw in_body(k, e);
    }
    world::BodyDef def{.name = b.name,
                       .model = rs.model,
                       .simulation = make_scene_simulation(rs),
                       .tools = make_tool_driver(rs.scene, /*warn_scalpels=*/!scalpels_cut)};
    try {
      ready->ids.push_back(world::create_body(ready->world, std::move(def)));
    } catch (const Error& e) {
      throw Error(e.kind(), scene.source + ": " + e.what());
    }
    ready->bodies.push_back(std::move(rs));
  }
  for (const WorldAttachmentScene& a : scene.attachments) {
    world::AttachmentDef def = a.def;
    const world::BodyId ia = world::find_body(ready->world, a.body_a);
    const world::BodyId ib = world::find_body(ready->world, a.body_b);
    def.body_a = ia.index;
    def.generation_a = ia.generation;
    def.body_b = ib.index;
    def.generation_b = ib.generation;
    try {
      ready->attachments.push_back(world::create_attachment(ready->world, def));
    } catch (const Error& e) {
      throw Error(e.kind(), scene.source + ": " + e.what());
    }
  }
  return ready;
}

}  // namespace lamina::io
