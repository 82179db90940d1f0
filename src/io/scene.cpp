#include "lamina/io/scene.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string_view>

#include "io/scene_names.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/interact/contact.h"
#include "lamina/interact/grasp.h"

namespace lamina::io {
namespace {

using nlohmann::json;

// The file gives tool forces in newtons; the simulation works in mN (kg mm / s^2).
constexpr double kMilliNewtonsPerNewton = 1000.0;

// Every check of one document goes through this reader, so every message has the same shape:
// "SOURCE: key.path: problem".
class Reader {
 public:
  explicit Reader(const std::string& source) : source_(source) {}

  [[noreturn]] void fail(const std::string& path, const std::string& problem) const {
    throw invalid_input(source_, path + ": " + problem);
  }

  // Warns about keys the scene format does not know (a typo must not pass silently, but an
  // extra key such as a comment field must not stop a run either).
  void warn_unknown(const json& object, const std::string& path,
                    std::initializer_list<std::string_view> known) const {
    for (const auto& [key, value] : object.items()) {
      if (std::find(known.begin(), known.end(), key) != known.end()) continue;
      log::warn("{}: {}: unknown key, ignored", source_, join(path, key));
    }
  }

  static std::string join(const std::string& path, const std::string& key) {
    return path.empty() ? key : path + "." + key;
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

std::string got(double v) {
  return fmt::format("got {}", v);
}

// Reads an optional number key and checks it with `ok`; `rule` says what `ok` wants.
template <class Ok>
void read_number(const Reader& r, const json& object, const std::string& path, const char* key,
                 double& out, Ok ok, const char* rule) {
  const auto it = object.find(key);
  if (it == object.end()) return;
  const std::string p = Reader::join(path, key);
  const double v = r.number(*it, p);
  if (!ok(v)) r.fail(p, std::string(rule) + ", " + got(v));
  out = v;
}

// Reads a string key that must be one of `choices`' spellings (scene_names.h); leaves `out` alone
// if absent.
template <class Enum, size_t N>
void read_choice(const Reader& r, const json& object, const std::string& path, const char* key,
                 Enum& out, const detail::Spelling<Enum> (&choices)[N]) {
  const auto it = object.find(key);
  if (it == object.end()) return;
  const std::string p = Reader::join(path, key);
  const std::string v = r.string(*it, p);
  std::string expected;  // "a" or "b"; "a", "b" or "c"
  size_t k = 0;
  for (const auto& [name, value] : choices) {
    if (v == name) {
      out = value;
      return;
    }
    const char* sep = k == 0 ? "" : k + 1 == N ? " or " : ", ";
    expected += sep + ("\"" + std::string(name) + "\"");
    ++k;
  }
  r.fail(p, "expected " + expected + ", got \"" + v + "\"");
}

template <class Int>
void read_integer(const Reader& r, const json& object, const std::string& path, const char* key,
                  Int& out, int64_t lo, int64_t hi) {
  const auto it = object.find(key);
  if (it == object.end()) return;
  out = static_cast<Int>(r.integer(*it, Reader::join(path, key), lo, hi));
}

void read_bool(const Reader& r, const json& object, const std::string& path, const char* key,
               bool& out) {
  const auto it = object.find(key);
  if (it != object.end()) out = r.boolean(*it, Reader::join(path, key));
}

const auto kPositive = [](double v) { return v > 0.0; };
const auto kNonNegative = [](double v) { return v >= 0.0; };
const auto kFraction = [](double v) { return v >= 0.0 && v <= 1.0; };

void read_model(const Reader& r, const json& j, Scene& s) {
  const std::string path = "model";
  r.require_object(j, path);
  r.warn_unknown(j, path, {"input", "model", "build"});
  const bool has_input = j.contains("input"), has_model = j.contains("model");
  if (has_input && has_model)
    r.fail(path,
           "give either \"input\" (a mask to build from) or \"model\" (a saved .vtu), "
           "not both");
  if (has_input) s.input = r.string(j["input"], "model.input");
  if (has_model) {
    s.model_path = r.string(j["model"], "model.model");
    s.input.clear();
  }
  const auto b = j.find("build");
  if (b == j.end()) return;
  const std::string bp = "model.build";
  r.require_object(*b, bp);
  if (has_model)
    log::warn("{}: {}: ignored: the model is loaded from \"{}\", not built", s.source, bp,
              s.model_path);
  r.warn_unknown(*b, bp,
                 {"structure", "layers", "skin_vertices", "layer_depth_mm", "label", "locality",
                  "links", "tet_radius_edge_ratio", "tet_min_dihedral_deg"});
  model::BuildOptions& o = s.build;
  s.structure_given = b->contains("structure");
  read_choice(r, *b, bp, "structure", o.structure, detail::kStructures);
  // Ranges are build_model's (check_build_options), checked here so messages name the key.
  read_integer(r, *b, bp, "layers", o.layers, 1, 16);
  read_integer(r, *b, bp, "skin_vertices", o.skin_vertices, 50, 5'000'000);
  read_number(r, *b, bp, "layer_depth_mm", o.layer_depth_mm, kNonNegative,
              "must be >= 0 (0 = automatic)");
  read_integer(r, *b, bp, "label", o.label, 0, std::numeric_limits<int32_t>::max());
  read_integer(r, *b, bp, "locality", o.locality, 1, 64);
  read_integer(r, *b, bp, "links", o.inter_layer_links, 1, 16);
  read_number(
      r, *b, bp, "tet_radius_edge_ratio", o.tet_radius_edge_ratio,
      [](double v) { return v >= 1.2 && v <= 10.0; }, "must be between 1.2 and 10");
  read_number(
      r, *b, bp, "tet_min_dihedral_deg", o.tet_min_dihedral_deg,
      [](double v) { return v >= 0.0 && v <= 18.0; }, "must be between 0 and 18 degrees");
}

void read_material(const Reader& r, const json& j, Scene& s) {
  const std::string path = "material";
  r.require_object(j, path);
  r.warn_unknown(j, path,
                 {"stiffness_n_per_m", "damping_kg_per_s", "node_mass_kg",
                  "anchor_stiffness_n_per_m", "gravity_mm_per_s2", "density_g_per_cm3", "density",
                  "mass_damping_per_s", "volume_stiffness_kpa", "young_modulus_kpa",
                  "poisson_ratio", "damping_ratio", "tet_elasticity", "model"});
  sim::Material& m = s.material;
  const bool paper = j.contains("stiffness_n_per_m") || j.contains("node_mass_kg");
  if (j.contains("young_modulus_kpa")) {
    // A physical tissue: the spring constants and masses follow from E, nu and the density, so
    // the paper's raw constants cannot be given beside them.
    for (const char* raw : {"stiffness_n_per_m", "node_mass_kg"})
      if (j.contains(raw))
        r.fail(path + "." + raw,
               "cannot be given with young_modulus_kpa (springs and masses then follow from "
               "E, nu and the density); remove one of them");
  } else if (paper) {
    // The paper's constants: the rest of the material, the solver and the structure take the
    // paper's values unless the file says otherwise (the solver and model keys come later or
    // were read before: an explicit structure stays).
    const Scene p = paper_scene();
    s.elastic = false;
    m = p.material;
    s.solver.integrator = p.solver.integrator;
    s.solver.dt_s = p.solver.dt_s;
    s.routing.routing = p.routing.routing;
    if (!s.structure_given) s.build.structure = p.build.structure;
  }
  read_choice(r, j, path, "tet_elasticity", s.tet_elasticity, detail::kTetElasticities);
  read_choice(r, j, path, "model", s.tet_model, detail::kTetModels);
  for (const char* key : {"poisson_ratio", "model"})
    if (j.contains(key) && !s.elastic)
      r.fail(path + "." + key, "needs young_modulus_kpa beside it");
  read_number(r, j, path, "young_modulus_kpa", s.elastic_material.young_modulus_kpa, kPositive,
              "must be > 0 (healthy liver: about 6 kPa)");
  read_number(
      r, j, path, "poisson_ratio", s.elastic_material.poisson_ratio,
      [](double v) { return v >= 0.0 && v < 0.5; }, "must be in [0, 0.5) (soft tissue: 0.45-0.49)");
  read_number(r, j, path, "damping_ratio", s.damping_ratio, kNonNegative,
              "must be >= 0 (1 = critically damped slowest mode)");
  read_number(r, j, path, "mass_damping_per_s", m.mass_damping_per_s, kNonNegative, "must be >= 0");
  read_number(r, j, path, "volume_stiffness_kpa", m.volume_stiffness_kpa, kNonNegative,
              "must be >= 0 (0 = no volume term)");
  s.volume_stiffness_given = j.contains("volume_stiffness_kpa");
  s.damping_given = j.contains("damping_kg_per_s") || j.contains("mass_damping_per_s");
  if (!s.elastic && j.contains("damping_ratio"))
    r.fail(path + ".damping_ratio",
           "needs a physical material (young_modulus_kpa), not the paper's raw constants");
  if (s.damping_given && s.damping_ratio >= 0.0)
    r.fail(path + ".damping_ratio",
           "cannot be given with damping_kg_per_s or mass_damping_per_s; remove one of them");
  read_number(r, j, path, "stiffness_n_per_m", m.stiffness_n_per_m, kNonNegative,
              "must be >= 0 (0 keeps the model's)");
  read_number(r, j, path, "damping_kg_per_s", m.damping_kg_per_s, kNonNegative, "must be >= 0");
  read_number(r, j, path, "node_mass_kg", m.node_mass_kg, kNonNegative,
              "must be >= 0 (0 = the model's lumped masses)");
  read_number(r, j, path, "anchor_stiffness_n_per_m", m.anchor_stiffness_n_per_m, kNonNegative,
              "must be >= 0");
  if (j.contains("gravity_mm_per_s2"))
    m.gravity_mm_per_s2 = r.vec3(j["gravity_mm_per_s2"], "material.gravity_mm_per_s2");
  if (j.contains("density_g_per_cm3") && j.contains("density"))
    r.fail(path + ".density", "give density_g_per_cm3 or density (the same, g/cm^3), not both");
  for (const char* key : {"density_g_per_cm3", "density"}) {
    if (!j.contains(key)) continue;
    double g_per_cm3 = 0.0;
    read_number(r, j, path, key, g_per_cm3, kPositive, "must be > 0 g/cm^3 (liver: 1.06)");
    s.build.density_kg_per_mm3 = g_per_cm3 * 1e-6;  // 1 g/cm^3 = 1e-3 kg / 1e3 mm^3
    s.density_given = true;
  }
}

void read_solver(const Reader& r, const json& j, Scene& s) {
  const std::string path = "solver";
  r.require_object(j, path);
  r.warn_unknown(j, path,
                 {"integrator", "dt_s", "rest_speed_mm_per_s", "threshold_mm", "max_steps", "mode",
                  "routing", "locality", "penetration_depth", "ring_attenuation",
                  "crossing_attenuation", "contact_threshold_mm", "cg_max_iterations",
                  "cg_tolerance", "preconditioner", "projective_iterations"});
  sim::SolverOptions& o = s.solver;
  s.integrator_given = j.contains("integrator");
  read_choice(r, j, path, "integrator", o.integrator, detail::kIntegrators);
  read_number(r, j, path, "dt_s", o.dt_s, kPositive, "must be > 0");
  // "At rest" is a speed, so that it does not depend on dt. The paper's threshold is a move per
  // step: the same test at the scene's dt (exactly: a step moves a node by dt times its new
  // velocity in every integrator).
  if (j.contains("rest_speed_mm_per_s") && j.contains("threshold_mm"))
    r.fail(path + ".threshold_mm",
           "give either rest_speed_mm_per_s or the paper's threshold_mm (a move per step), not "
           "both");
  read_number(r, j, path, "rest_speed_mm_per_s", o.rest_speed_mm_per_s, kPositive, "must be > 0");
  double threshold_mm = 0.0;
  read_number(r, j, path, "threshold_mm", threshold_mm, kPositive, "must be > 0");
  if (threshold_mm > 0.0) o.rest_speed_mm_per_s = threshold_mm / o.dt_s;
  read_integer(r, j, path, "max_steps", o.max_steps, 1, std::numeric_limits<int64_t>::max());
  read_choice(r, j, path, "mode", o.mode, detail::kModes);
  read_integer(r, j, path, "cg_max_iterations", o.cg_max_iterations, 1, 1'000'000);
  read_number(r, j, path, "cg_tolerance", o.cg_tolerance, kPositive, "must be > 0");
  read_choice(r, j, path, "preconditioner", o.preconditioner, detail::kPreconditioners);
  read_integer(r, j, path, "projective_iterations", o.projective_iterations, 1, 10'000);
  interact::RoutingOptions& ro = s.routing;
  read_choice(r, j, path, "routing", ro.routing, detail::kRoutings);
  read_integer(r, j, path, "locality", ro.locality, 1, 64);
  read_integer(r, j, path, "penetration_depth", ro.penetration_depth, 1, 1'000'000);
  read_number(r, j, path, "ring_attenuation", ro.ring_attenuation, kFraction,
              "must be between 0 and 1");
  read_number(r, j, path, "crossing_attenuation", ro.crossing_attenuation, kFraction,
              "must be between 0 and 1");
  read_number(r, j, path, "contact_threshold_mm", ro.contact_threshold_mm, kPositive,
              "must be > 0");
}

void read_tools(const Reader& r, const json& j, Scene& s) {
  if (!j.is_array())
    r.fail("tools", "expected an array of tools [...], got " + Reader::describe(j));
  s.default_tool = false;
  for (size_t k = 0; k < j.size(); ++k) {
    const std::string path = "tools[" + std::to_string(k) + "]";
    const json& t = j[k];
    r.require_object(t, path);
    r.warn_unknown(t, path,
                   {"point", "vertex", "force_n", "drag_mm", "gain_n_per_mm", "start_s", "end_s",
                    "radius_mm", "grasp"});
    interact::Tool tool;
    const bool has_point = t.contains("point"), has_vertex = t.contains("vertex");
    if (has_point == has_vertex)
      r.fail(path, has_point ? "give either \"point\" or \"vertex\", not both"
                             : "needs \"point\": [x, y, z] (mm) or \"vertex\": skin node index");
    if (has_point) {
      tool.by_point = true;
      tool.point_mm = r.vec3(t["point"], path + ".point");
    } else {
      tool.vertex = static_cast<int32_t>(
          r.integer(t["vertex"], path + ".vertex", 0, std::numeric_limits<int32_t>::max()));
    }
    // A grasper: its jaws close on the skin at the point and pull it.
    if (const auto g = t.find("grasp"); g != t.end()) {
      const std::string gp = path + ".grasp";
      r.require_object(*g, gp);
      r.warn_unknown(*g, gp, {"pull_mm", "pull_s"});
      for (const char* force_key : {"force_n", "drag_mm", "gain_n_per_mm"})
        if (t.contains(force_key))
          r.fail(path + "." + force_key, "a grasper pulls by grasp.pull_mm; it takes no force");
      tool.grasp = true;
      if (g->contains("pull_mm")) tool.pull_mm = r.vec3((*g)["pull_mm"], gp + ".pull_mm");
      read_number(r, *g, gp, "pull_s", tool.pull_s, kPositive, "must be > 0 s");
    }
    // The force is given directly, or (the paper's interaction) proportional to a drag:
    // force = gain x drag vector.
    const bool has_force = t.contains("force_n"), has_drag = t.contains("drag_mm");
    if (tool.grasp) {
      // no force: what it pulls is where the jaws go
    } else if (has_force == has_drag)
      r.fail(path,
             has_force
                 ? "give either \"force_n\" or \"drag_mm\", not both"
                 : "needs \"force_n\": [fx, fy, fz] (newtons) or \"drag_mm\": [dx, dy, dz] (mm)");
    if (tool.grasp) {
      // no force to read
    } else if (has_force) {
      if (t.contains("gain_n_per_mm"))
        r.fail(path + ".gain_n_per_mm", "only applies with \"drag_mm\"");
      tool.force_mn = kMilliNewtonsPerNewton * r.vec3(t["force_n"], path + ".force_n");
    } else {
      double gain = 0.05;
      read_number(r, t, path, "gain_n_per_mm", gain, kPositive, "must be > 0 N/mm");
      tool.force_mn = kMilliNewtonsPerNewton * gain * r.vec3(t["drag_mm"], path + ".drag_mm");
    }
    read_number(r, t, path, "start_s", tool.start_s, kNonNegative, "must be >= 0");
    read_number(
        r, t, path, "radius_mm", tool.radius_mm,
        [&](double v) { return tool.grasp ? v > 0.0 : v >= 0.0; },
        tool.grasp ? "must be > 0 mm (skin within it is grasped)"
                   : "must be >= 0 mm (the patch the force is spread over without "
                     "routing; 0 = a point)");
    // A null end means the tool never lets go (the same as leaving the key out).
    if (t.contains("end_s") && !t["end_s"].is_null()) {
      read_number(
          r, t, path, "end_s", tool.end_s, [&](double v) { return v > tool.start_s; },
          fmt::format("must be after start_s ({})", tool.start_s).c_str());
    }
    s.tools.push_back(tool);
  }
}

void read_boundary(const Reader& r, const json& j, Scene& s) {
  const std::string path = "boundary";
  r.require_object(j, path);
  r.warn_unknown(j, path, {"fixed", "support"});
  s.default_fixed = false;
  if (const auto sup = j.find("support"); sup != j.end()) {
    if (!sup->is_array())
      r.fail("boundary.support",
             "expected an array of supported surfaces [...], got " + Reader::describe(*sup));
    for (size_t k = 0; k < sup->size(); ++k) {
      const std::string sp = "boundary.support[" + std::to_string(k) + "]";
      const json& reg = (*sup)[k];
      r.require_object(reg, sp);
      r.warn_unknown(reg, sp, {"direction", "max_angle_deg", "stiffness_kpa_per_mm"});
      model::SurfaceSupportOptions o;
      if (reg.contains("direction")) {
        o.direction = r.vec3(reg["direction"], sp + ".direction");
        if (!(o.direction.norm() > 0.0)) r.fail(sp + ".direction", "must not be zero");
      }
      read_number(
          r, reg, sp, "max_angle_deg", o.max_angle_deg,
          [](double v) { return v >= 0.0 && v <= 180.0; }, "must be between 0 and 180 degrees");
      read_number(r, reg, sp, "stiffness_kpa_per_mm", o.stiffness_kpa_per_mm, kNonNegative,
                  "must be >= 0 kPa/mm");
      s.support.push_back(o);
    }
  }
  const auto f = j.find("fixed");
  if (f == j.end()) return;
  if (!f->is_array())
    r.fail("boundary.fixed", "expected an array of regions [...], got " + Reader::describe(*f));
  for (size_t k = 0; k < f->size(); ++k) {
    const std::string rp = "boundary.fixed[" + std::to_string(k) + "]";
    const json& reg = (*f)[k];
    r.require_object(reg, rp);
    r.warn_unknown(reg, rp, {"plane", "nodes"});
    if (!reg.contains("plane") && !reg.contains("nodes"))
      r.fail(rp, "needs \"plane\": {point, normal, distance_mm} and/or \"nodes\": [indices]");
    FixedRegion region;
    if (reg.contains("plane")) {
      const std::string pp = rp + ".plane";
      const json& p = reg["plane"];
      r.require_object(p, pp);
      r.warn_unknown(p, pp, {"point", "normal", "distance_mm"});
      region.has_plane = true;
      if (!p.contains("point")) r.fail(pp, "needs \"point\": [x, y, z] (mm)");
      if (!p.contains("normal")) r.fail(pp, "needs \"normal\": [nx, ny, nz]");
      region.plane_point_mm = r.vec3(p["point"], pp + ".point");
      region.plane_normal = r.vec3(p["normal"], pp + ".normal");
      if (!(region.plane_normal.norm() > 0.0)) r.fail(pp + ".normal", "must not be zero");
      read_number(r, p, pp, "distance_mm", region.distance_mm, kNonNegative, "must be >= 0");
    }
    if (reg.contains("nodes")) {
      const std::string np = rp + ".nodes";
      const json& n = reg["nodes"];
      if (!n.is_array())
        r.fail(np, "expected an array of node indices, got " + Reader::describe(n));
      for (size_t i = 0; i < n.size(); ++i)
        region.nodes.push_back(static_cast<int32_t>(r.integer(
            n[i], np + "[" + std::to_string(i) + "]", 0, std::numeric_limits<int32_t>::max())));
    }
    s.fixed.push_back(std::move(region));
  }
}

void read_output(const Reader& r, const json& j, Scene& s) {
  const std::string path = "output";
  r.require_object(j, path);
  r.warn_unknown(j, path, {"frame_interval_s", "all_layers", "obj", "metrics_every_step"});
  read_number(r, j, path, "frame_interval_s", s.output.frame_interval_s, kNonNegative,
              "must be >= 0 (0 = first and final frames only)");
  read_bool(r, j, path, "all_layers", s.output.all_layers);
  read_bool(r, j, path, "obj", s.output.obj);
  read_bool(r, j, path, "metrics_every_step", s.output.metrics_every_step);
}

}  // namespace

Scene parse_scene(const std::string& json_text, const std::string& source_name) {
  Scene s;
  s.source = source_name;
  const Reader r(s.source);
  json doc;
  try {
    // Comments are allowed: a scene file is written by hand and worth annotating.
    doc = json::parse(json_text, nullptr, true, true);
  } catch (const json::exception& e) {
    // "[json.exception.parse_error.101] parse error at line 3, column 5: ...": the bracketed
    // tag means nothing to a person editing the file.
    std::string what = e.what();
    if (!what.empty() && what[0] == '[' && what.find("] ") != std::string::npos)
      what = what.substr(what.find("] ") + 2);
    throw invalid_input(source_name, "invalid JSON: " + what);
  }
  if (!doc.is_object())
    throw invalid_input(source_name,
                        "expected a JSON object {...} at the top, got " + Reader::describe(doc));
  r.warn_unknown(doc, "", {"model", "material", "solver", "tools", "boundary", "output"});
  if (doc.contains("model")) read_model(r, doc["model"], s);
  if (doc.contains("material")) read_material(r, doc["material"], s);
  if (doc.contains("solver")) read_solver(r, doc["solver"], s);
  if (doc.contains("tools")) read_tools(r, doc["tools"], s);
  if (doc.contains("boundary")) read_boundary(r, doc["boundary"], s);
  if (doc.contains("output")) read_output(r, doc["output"], s);
  // Rings must reach as far as the routing spreads force.
  s.build.locality = std::max(s.build.locality, s.routing.locality);
  return s;
}

Scene load_scene(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw invalid_input(path, "is a folder, not a scene file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw invalid_input(path, "cannot open the scene file (does it exist?)");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw invalid_input(path, "cannot read the scene file");
  Scene s = parse_scene(text.str(), path);
  const fs::path folder = fs::path(path).parent_path();
  auto resolve = [&](std::string& p) {
    if (!p.empty() && fs::path(p).is_relative()) p = (folder / p).lexically_normal().string();
  };
  if (s.input != kScenePhantom) resolve(s.input);
  resolve(s.model_path);
  return s;
}

Scene paper_scene() {
  Scene s;
  s.source = "the paper's scene";
  s.build.structure = model::Structure::kLinks;
  s.elastic = false;
  s.material = sim::Material{};     // K = 3 N/m, gamma = 3 kg/s, unit masses
  s.solver = sim::SolverOptions{};  // semi-implicit Euler, dt = 0.01 s, 1e-3 mm per step
  s.routing.routing = interact::Routing::kPaper;
  return s;
}

void use_elastic_material(Scene& s) {
  s.elastic = true;
  s.material.stiffness_n_per_m = 0.0;
  s.material.node_mass_kg = 0.0;
  if (!s.damping_given) s.material.damping_kg_per_s = 0.0;
}

void resolve_scene_defaults(Scene& s, const Model& m) {
  if (s.default_tool) {
    // The paper's poke: the most anterior skin node, pushed posteriorly.
    s.tools.push_back({.by_point = false,
                       .vertex = interact::most_anterior_skin_node(m),
                       .force_mn = Eigen::Vector3d(0.0, 0.4 * kMilliNewtonsPerNewton, 0.0),
                       .start_s = 0.0,
                       .end_s = 1.0});
    s.default_tool = false;
  }
  if (s.default_fixed && s.elastic) {
    // Held at the back, where the liver rests against the diaphragm and the posterior wall, by
    // tissue rather than a clamp: a push dents it where it is pushed.
    s.support.push_back({});
    s.default_fixed = false;
  }
  if (s.default_fixed) {
    // The paper's: the posterior 10 mm held in place.
    const double back = m.X.col(1).maxCoeff();
    s.fixed.push_back({.has_plane = true,
                       .plane_point_mm = Eigen::Vector3d(0.0, back, 0.0),
                       .plane_normal = Eigen::Vector3d::UnitY(),
                       .distance_mm = 10.0,
                       .nodes = {}});
    s.default_fixed = false;
  }
}

void check_scene_against_model(const Scene& s, const Model& m) {
  const Reader r(s.source);
  if (const auto p = interact::routing_problem(s.routing, m.rings.locality))
    r.fail("solver." + p->key, p->problem);
  const int32_t skin_nodes = m.layers.at(0).node_count;
  for (size_t k = 0; k < s.tools.size(); ++k) {
    const interact::Tool& t = s.tools[k];
    const std::string path = "tools[" + std::to_string(k) + "]";
    if (!t.by_point && (t.vertex < 0 || t.vertex >= skin_nodes))
      r.fail(path + ".vertex",
             fmt::format("must be a skin node, 0..{}, got {}", skin_nodes - 1, t.vertex));
    if (t.by_point) {
      const double depth = interact::depth_under_skin(m, m.X, t.point_mm);
      if (depth > interact::start_depth_limit_mm(t.radius_mm))
        r.fail(path + ".point",
               fmt::format("[{}, {}, {}] is inside the organ, {:.1f} mm under the skin at rest: a "
                           "tool starts outside the organ or on its skin",
                           t.point_mm.x(), t.point_mm.y(), t.point_mm.z(), depth));
    }
    if (t.grasp) {
      // Something under the jaws at rest, or nothing to hold.
      const Eigen::Vector3d at = t.by_point ? t.point_mm : Eigen::Vector3d(m.X.row(t.vertex));
      if (!interact::anything_under_jaws(m, m.X, {.center_mm = at, .radius_mm = t.radius_mm}))
        r.fail(path + (t.by_point ? ".point" : ".vertex"),
               fmt::format("nothing under the grasper's jaws: no skin node within radius_mm "
                           "({} mm) of [{}, {}, {}] at rest",
                           t.radius_mm, at.x(), at.y(), at.z()));
      continue;
    }
    // The same contact the tool will make: the nearest skin node for the paper's routing, the
    // nearest point of the skin without it.
    if (t.by_point &&
        interact::load_at_point(m, m.X, t.point_mm, Eigen::Vector3d::Zero(), 0.0, s.routing)
                .contact_node < 0)
      r.fail(path + ".point",
             fmt::format("[{}, {}, {}] is farther than solver.contact_threshold_mm ({} mm) from "
                         "the skin at rest",
                         t.point_mm.x(), t.point_mm.y(), t.point_mm.z(),
                         s.routing.contact_threshold_mm));
  }
  for (size_t k = 0; k < s.fixed.size(); ++k)
    for (size_t i = 0; i < s.fixed[k].nodes.size(); ++i)
      if (s.fixed[k].nodes[i] >= m.node_count())
        r.fail(fmt::format("boundary.fixed[{}].nodes[{}]", k, i),
               fmt::format("must be a node of the model, 0..{}, got {}", m.node_count() - 1,
                           s.fixed[k].nodes[i]));
}

std::vector<int32_t> fixed_scene_nodes(const Scene& s, const Model& m) {
  std::vector<int32_t> out;
  for (const FixedRegion& f : s.fixed) {
    if (f.has_plane) {
      const std::vector<int32_t> near =
          sim::nodes_near_plane(m, f.plane_point_mm, f.plane_normal, f.distance_mm);
      out.insert(out.end(), near.begin(), near.end());
    }
    out.insert(out.end(), f.nodes.begin(), f.nodes.end());
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::string integrator_name(sim::Integrator integrator) {
  return std::string(detail::name_of(detail::kIntegrators, integrator));
}

std::string preconditioner_name(sim::Preconditioner preconditioner) {
  return std::string(detail::name_of(detail::kPreconditioners, preconditioner));
}

std::string routing_name(interact::Routing routing) {
  return std::string(detail::name_of(detail::kRoutings, routing));
}

std::string tet_model_name(sim::TetModel model) {
  return std::string(detail::name_of(detail::kTetModels, model));
}

std::string mode_name(sim::Mode mode) {
  return std::string(detail::name_of(detail::kModes, mode));
}

std::string run_summary_json(const RunSummary& s) {
  nlohmann::ordered_json j;  // keys in this order, the most telling first
  j["scene"] = s.scene;
  j["model"] = s.model;
  j["converged"] = s.converged;
  j["stopped"] = s.stopped;
  j["unstable"] = s.unstable;
  if (s.unstable) j["unstable_reason"] = s.unstable_reason;
  j["steps"] = s.steps;
  j["sim_seconds"] = s.sim_seconds;
  j["wall_seconds"] = s.wall_seconds;
  j["model_seconds"] = s.model_seconds;
  nlohmann::ordered_json stages = nlohmann::ordered_json::object();  // in the order they ran
  for (const auto& [name, sec] : s.setup_stage_seconds) stages[name] = sec;
  j["setup_stage_seconds"] = stages;
  j["max_displacement_mm"] = s.max_displacement_mm;
  j["max_abs_volume_change_pct"] = s.max_abs_volume_change_pct;
  j["final_rest_error_mm"] = s.final_rest_error_mm;
  j["final_volume_change_pct"] = s.final_volume_change_pct;
  j["nan_detected"] = s.recoveries > 0;
  j["recoveries"] = s.recoveries;
  j["integrator"] = integrator_name(s.integrator);
  j["mode"] = mode_name(s.mode);
  j["routing"] = routing_name(s.routing);
  if (!s.preconditioner.empty()) j["preconditioner"] = s.preconditioner;
  j["dt_s"] = s.dt_s;
  j["nodes"] = s.nodes;
  j["springs"] = s.springs;
  j["layers"] = s.layers;
  j["fixed_nodes"] = s.fixed_nodes;
  j["tools"] = s.tools;
  j["steps_per_second"] = s.steps_per_second;
  j["mean_step_us"] = s.mean_step_us;
  j["median_step_us"] = s.median_step_us;
  j["frames"] = s.frames;
  j["max_reaction_n"] = s.max_reaction_n;
  {
    const MaterialReport& m = s.material;
    nlohmann::ordered_json mj;
    mj["elastic"] = m.elastic;
    if (m.elastic) {
      mj["young_modulus_kpa"] = m.elastic_material.young_modulus_kpa;
      mj["poisson_ratio"] = m.elastic_material.poisson_ratio;
      mj["structure"] = std::string(detail::name_of(
          detail::kStructures, m.tets ? model::Structure::kTetrahedra : model::Structure::kLinks));
      if (m.tets) {
        mj["model"] = tet_model_name(m.tet_model);
        mj["tet_elasticity"] =
            std::string(detail::name_of(detail::kTetElasticities, m.tet_elasticity));
        mj["tet_volume_modulus_kpa"] = m.tet_volume_modulus_kpa;
      } else {
        mj["shear_modulus_kpa"] = m.identification.shear_modulus_kpa;
        mj["spring_fit_residual"] = m.identification.fit_residual;
      }
    }
    mj["supported_nodes"] = m.supported_nodes;
    mj["supported_area_mm2"] = m.supported_area_mm2;
    mj["volume_stiffness_kpa"] = m.volume_stiffness_kpa;
    mj["mass_damping_per_s"] = m.mass_damping_per_s;
    if (m.damping_ratio >= 0.0) {
      mj["damping_ratio"] = m.damping_ratio;
      mj["lowest_frequency_hz"] = m.lowest_frequency_hz;
    }
    mj["explicit_dt_limit_s"] = m.explicit_dt_limit_s;
    j["material"] = mj;
  }
  j["realtime"] = s.realtime;
  if (s.realtime) {
    j["rate_hz"] = s.rate_hz;
    j["achieved_rate_hz"] = s.achieved_rate_hz;
    j["real_time_factor"] = s.real_time_factor;
    j["kept_up"] = s.kept_up;
    j["worst_jitter_us"] = s.worst_jitter_us;
    j["p99_jitter_us"] = s.p99_jitter_us;
  }
  return j.dump(2);
}

}  // namespace lamina::io
