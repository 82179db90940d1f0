// Reading a scene file (parse_scene, load_scene): each object of the file is one table of keys
// below (how a table is read: scene_keys.h). A table drives both the reading and the warning
// about unknown keys, so a key is named once; a key that needs more than a type and a range
// check has a small reader of its own. Rules across keys ("cannot be given with ...") are
// checked where the reader has always checked them - before an object's keys, or as a row's
// `before` - so that a scene with several mistakes is told of the same one first.
#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

#include "io/scene_keys.h"
#include "io/scene_object.h"
#include "lamina/io/scene.h"

namespace lamina::io {
namespace {

using detail::at;
using detail::boolean;
using detail::choice;
using detail::given;
using detail::integer;
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
using detail::vec3;
using interact::Tool;
using Build = model::BuildOptions;
using Solver = sim::SolverOptions;
using Routing = interact::RoutingOptions;
using Material = sim::Material;
using Support = model::SurfaceSupportOptions;

// The scene's fields inside its options structs: in_build<&Build::layers> is scene.build.layers.
template <auto Member>
inline constexpr auto in_build = at<&Scene::build, Member>;
template <auto Member>
inline constexpr auto in_material = at<&Scene::material, Member>;
template <auto Member>
inline constexpr auto in_solver = at<&Scene::solver, Member>;
template <auto Member>
inline constexpr auto in_routing = at<&Scene::routing, Member>;
template <auto Member>
inline constexpr auto in_output = at<&Scene::output, Member>;

constexpr int64_t kInt32Max = std::numeric_limits<int32_t>::max();

// model.build.embed[k]: a structure of the same segmentation, {"label": L, "name": "vessels",
// "role": "vessel"} (the role optional: the one the name suggests).
void read_embed(const Value& v, Scene& s) {
  using Embed = model::EmbedStructure;
  static const Keys<Embed> kKeys = {
      {"label", integer(&Embed::label, 1, kInt32Max)},
      {"name", [](const Value& n, Embed& e) { e.name = n.string(); }},
      {"role",
       [](const Value& n, Embed& e) {
         const std::string word = n.string();
         const auto r = role_from_name(word);
         if (!r || !is_anatomy(*r))
           n.fail("expected \"vessel\", \"tumour\" or \"structure\", got \"" + word + "\"");
         e.role = *r;
       }},
  };
  if (!v.data.is_array())
    v.fail("expected an array of structures [{\"label\": 2, \"name\": \"vessels\"}, ...], got " +
           Reader::describe(v.data));
  for (size_t k = 0; k < v.data.size(); ++k) {
    const std::string path = v.path + "[" + std::to_string(k) + "]";
    const Object in = open_object(v.in.r, v.data[k], path, kKeys);
    if (!in.has("label")) in.r.fail(path, "needs \"label\": the structure's label");
    Embed e;
    read_keys(in, kKeys, e);
    s.build.embed.push_back(std::move(e));
  }
}

// model.build.labels: the organ as the union of several labels.
void read_labels(const Value& v, Scene& s) {
  if (!v.data.is_array() || v.data.empty())
    v.fail("expected an array of labels [1, 5], got " + Reader::describe(v.data));
  for (size_t k = 0; k < v.data.size(); ++k)
    s.build.labels.push_back(static_cast<int32_t>(
        v.in.r.integer(v.data[k], v.path + "[" + std::to_string(k) + "]", 1, kInt32Max)));
}

// model.build: how the model is built from its mask.
void read_build(const Value& v, Scene& s) {
  // Ranges are build_model's (check_build_options), checked here so messages name the key.
  static const Keys<Scene> kKeys = {
      {"structure",
       given(&Scene::structure_given, choice(in_build<&Build::structure>, detail::kStructures))},
      {"layers", integer(in_build<&Build::layers>, 1, 16)},
      {"skin_vertices", integer(in_build<&Build::skin_vertices>, 50, 5'000'000)},
      {"layer_depth_mm",
       number(in_build<&Build::layer_depth_mm>, non_negative, "must be >= 0 (0 = automatic)")},
      {"label", integer(in_build<&Build::label>, 0, kInt32Max)},
      {"labels", read_labels},
      {"display_triangles", integer(in_build<&Build::display_triangles>, 0, 10'000'000)},
      {"structure_triangles", integer(in_build<&Build::structure_triangles>, 100, 10'000'000)},
      {"embed", read_embed},
      {"locality", integer(in_build<&Build::locality>, 1, 64)},
      {"links", integer(in_build<&Build::inter_layer_links>, 1, 16)},
      {"tet_radius_edge_ratio",
       number(
           in_build<&Build::tet_radius_edge_ratio>, [](double r) { return r >= 1.2 && r <= 10.0; },
           "must be between 1.2 and 10")},
      {"tet_min_dihedral_deg",
       number(
           in_build<&Build::tet_min_dihedral_deg>, [](double d) { return d >= 0.0 && d <= 18.0; },
           "must be between 0 and 18 degrees")},
  };
  v.in.r.require_object(v.data, v.path);
  if (v.in.has("model"))
    log::warn("{}: {}: ignored: the model is loaded from \"{}\", not built", s.source, v.path,
              s.model_path);
  v.in.r.warn_unknown(v.data, v.path, kKeys);
  read_keys(Object{v.in.r, v.data, v.path}, kKeys, s);
}

void read_model(const Value& v, Scene& s) {
  static const Keys<Scene> kKeys = {
      {"input", [](const Value& input, Scene& sc) { sc.input = input.string(); }},
      {"model",
       [](const Value& m, Scene& sc) {
         sc.model_path = m.string();
         sc.input.clear();
       }},
      {"build", read_build},
  };
  const Object model = open_object(v.in.r, v.data, v.path, kKeys);
  if (model.has("input") && model.has("model"))
    v.fail(
        "give either \"input\" (a mask to build from) or \"model\" (a saved .vtu), "
        "not both");
  read_keys(model, kKeys, s);
}

// material.density_g_per_cm3, or its alias density.
void read_density(const Value& v, Scene& s) {
  const double g_per_cm3 = v.number(positive, "must be > 0 g/cm^3 (liver: 1.06)");
  s.build.density_kg_per_mm3 = g_per_cm3 * 1e-6;  // 1 g/cm^3 = 1e-3 kg / 1e3 mm^3
  s.density_given = true;
}

// Rules across material keys, each checked at the row it precedes in the table (where the reader
// has always checked it).

// poisson_ratio and model describe a physical material, not the paper's raw constants.
void physical_keys_need_young_modulus(const Object& in, Scene& s) {
  for (const char* key : {"poisson_ratio", "model"})
    if (in.has(key) && !s.elastic) in.fail(key, "needs young_modulus_kpa beside it");
}

// One source of damping: a ratio of a physical material's slowest mode, or raw values.
void one_source_of_damping(const Object& in, Scene& s) {
  if (!s.elastic && in.has("damping_ratio"))
    in.fail("damping_ratio",
            "needs a physical material (young_modulus_kpa), not the paper's raw constants");
  if ((in.has("damping_kg_per_s") || in.has("mass_damping_per_s")) && s.damping_ratio >= 0.0)
    in.fail("damping_ratio",
            "cannot be given with damping_kg_per_s or mass_damping_per_s; remove one of them");
}

// density is density_g_per_cm3 by a shorter name.
void one_density(const Object& in, Scene&) {
  if (in.has("density_g_per_cm3") && in.has("density"))
    in.fail("density", "give density_g_per_cm3 or density (the same, g/cm^3), not both");
}

void read_material(const Value& v, Scene& s) {
  static const Keys<Scene> kKeys = {
      {"tet_elasticity", choice(&Scene::tet_elasticity, detail::kTetElasticities)},
      {"model", choice(&Scene::tet_model, detail::kTetModels)},
      {"young_modulus_kpa",
       number(at<&Scene::elastic_material, &model::ElasticMaterial::young_modulus_kpa>, positive,
              "must be > 0 (healthy liver: about 6 kPa)"),
       physical_keys_need_young_modulus},
      {"poisson_ratio", number(
                            at<&Scene::elastic_material, &model::ElasticMaterial::poisson_ratio>,
                            [](double nu) { return nu >= 0.0 && nu < 0.5; },
                            "must be in [0, 0.5) (soft tissue: 0.45-0.49)")},
      {"damping_ratio", number(&Scene::damping_ratio, non_negative,
                               "must be >= 0 (1 = critically damped slowest mode)")},
      {"mass_damping_per_s",
       given(&Scene::damping_given,
             number(in_material<&Material::mass_damping_per_s>, non_negative, "must be >= 0"))},
      {"volume_stiffness_kpa", given(&Scene::volume_stiffness_given,
                                     number(in_material<&Material::volume_stiffness_kpa>,
                                            non_negative, "must be >= 0 (0 = no volume term)"))},
      {"stiffness_n_per_m",
       number(in_material<&Material::stiffness_n_per_m>, non_negative,
              "must be >= 0 (0 keeps the model's)"),
       one_source_of_damping},
      {"damping_kg_per_s",
       given(&Scene::damping_given,
             number(in_material<&Material::damping_kg_per_s>, non_negative, "must be >= 0"))},
      {"node_mass_kg", number(in_material<&Material::node_mass_kg>, non_negative,
                              "must be >= 0 (0 = the model's lumped masses)")},
      {"anchor_stiffness_n_per_m",
       number(in_material<&Material::anchor_stiffness_n_per_m>, non_negative, "must be >= 0")},
      {"gravity_mm_per_s2", vec3(in_material<&Material::gravity_mm_per_s2>)},
      {"density_g_per_cm3", read_density, one_density},
      {"density", read_density},
  };
  const Object material = open_object(v.in.r, v.data, v.path, kKeys);
  if (material.has("young_modulus_kpa")) {
    // A physical tissue: the spring constants and masses follow from E, nu and the density, so
    // the paper's raw constants cannot be given beside them.
    for (const char* raw : {"stiffness_n_per_m", "node_mass_kg"})
      if (material.has(raw))
        material.fail(raw,
                      "cannot be given with young_modulus_kpa (springs and masses then follow "
                      "from E, nu and the density); remove one of them");
  } else if (material.has("stiffness_n_per_m") || material.has("node_mass_kg")) {
    // The paper's constants: the rest of the material, the solver and the structure take the
    // paper's values unless the file says otherwise (the solver and model keys come later or
    // were read before: an explicit structure stays).
    const Scene p = paper_scene();
    s.elastic = false;
    s.material = p.material;
    s.solver.integrator = p.solver.integrator;
    s.solver.dt_s = p.solver.dt_s;
    s.routing.routing = p.routing.routing;
    if (!s.structure_given) s.build.structure = p.build.structure;
  }
  read_keys(material, kKeys, s);
}

// "At rest" is a speed, so that it does not depend on dt. The paper's threshold is a move per
// step: the same test at the scene's dt (exactly: a step moves a node by dt times its new velocity
// in every integrator). Not both.
void rest_speed_or_threshold(const Object& in, Scene&) {
  if (in.has("rest_speed_mm_per_s") && in.has("threshold_mm"))
    in.fail("threshold_mm",
            "give either rest_speed_mm_per_s or the paper's threshold_mm (a move per step), not "
            "both");
}

void read_solver(const Value& v, Scene& s) {
  static const Keys<Scene> kKeys = {
      {"integrator", given(&Scene::integrator_given,
                           choice(in_solver<&Solver::integrator>, detail::kIntegrators))},
      {"dt_s", number(in_solver<&Solver::dt_s>, positive, "must be > 0")},
      {"rest_speed_mm_per_s",
       number(in_solver<&Solver::rest_speed_mm_per_s>, positive, "must be > 0"),
       rest_speed_or_threshold},
      {"threshold_mm",
       [](const Value& t, Scene& sc) {
         sc.solver.rest_speed_mm_per_s = t.number(positive, "must be > 0") / sc.solver.dt_s;
       }},
      {"max_steps", integer(in_solver<&Solver::max_steps>, 1, std::numeric_limits<int64_t>::max())},
      {"mode", choice(in_solver<&Solver::mode>, detail::kModes)},
      {"cg_max_iterations", integer(in_solver<&Solver::cg_max_iterations>, 1, 1'000'000)},
      {"cg_tolerance", number(in_solver<&Solver::cg_tolerance>, positive, "must be > 0")},
      {"preconditioner", choice(in_solver<&Solver::preconditioner>, detail::kPreconditioners)},
      {"projective_iterations", integer(in_solver<&Solver::projective_iterations>, 1, 10'000)},
      {"routing", choice(in_routing<&Routing::routing>, detail::kRoutings)},
      {"touch", choice(in_routing<&Routing::touch>, detail::kTouches)},
      {"locality", integer(in_routing<&Routing::locality>, 1, 64)},
      {"penetration_depth", integer(in_routing<&Routing::penetration_depth>, 1, 1'000'000)},
      {"ring_attenuation",
       number(in_routing<&Routing::ring_attenuation>, detail::fraction, "must be between 0 and 1")},
      {"crossing_attenuation", number(in_routing<&Routing::crossing_attenuation>, detail::fraction,
                                      "must be between 0 and 1")},
      {"contact_threshold_mm",
       number(in_routing<&Routing::contact_threshold_mm>, positive, "must be > 0")},
      // A length, or "paper": the organ's paper-size skin's edge, known once the model is.
      {"ring_spacing_mm",
       [](const Value& t, Scene& sc) {
         if (t.data.is_string()) {
           if (t.string() != "paper")
             t.fail("expected a number of mm or \"paper\", got \"" + t.string() + "\"");
           sc.routing.ring_spacing_mm = interact::kPaperRingSpacing;
           return;
         }
         sc.routing.ring_spacing_mm = t.number([](double d) { return d >= 0.0; },
                                               "must be >= 0 mm (0: rings in mesh edges)");
       }},
  };
  read_object(v.in.r, v.data, v.path, kKeys, s);
}

// tools[k].grasp: a grasper, whose jaws close on the skin at the tool's point and pull it.
void read_grasp(const Value& v, Tool& tool) {
  static const Keys<Tool> kKeys = {
      {"pull_mm", vec3(&Tool::pull_mm)},
      {"pull_s", number(&Tool::pull_s, positive, "must be > 0 s")},
  };
  const Object grasp = open_object(v.in.r, v.data, v.path, kKeys);
  for (const char* force_key : {"force_n", "drag_mm", "gain_n_per_mm"})
    if (v.in.has(force_key))
      v.in.fail(force_key, "a grasper pulls by grasp.pull_mm; it takes no force");
  tool.grasp = true;
  read_keys(grasp, kKeys, tool);
}

// The force is given directly, or (the paper's interaction) proportional to a drag:
// force = gain x drag vector. A grasper has none: what it pulls is where the jaws go.
void force_or_drag(const Object& in, Tool& tool) {
  if (tool.grasp) return;
  const bool has_force = in.has("force_n"), has_drag = in.has("drag_mm");
  if (has_force == has_drag)
    in.r.fail(in.path, has_force ? "give either \"force_n\" or \"drag_mm\", not both"
                                 : "needs \"force_n\": [fx, fy, fz] (newtons) or \"drag_mm\": "
                                   "[dx, dy, dz] (mm)");
  if (has_force && in.has("gain_n_per_mm"))
    in.fail("gain_n_per_mm", "only applies with \"drag_mm\"");
}

// tools[k].scalpel: a blade drawn along a path while the run goes, cutting the tetrahedra.
void read_scalpel(const Value& v, Scene& s) {
  using interact::Scalpel;
  static const Keys<Scalpel> kKeys = {
      {"path",
       [](const Value& p, Scalpel& sc) {
         if (!p.data.is_array() || p.data.size() < 2)
           p.fail("expected an array of at least two points [[x, y, z], ...], got " +
                  Reader::describe(p.data));
         for (size_t k = 0; k < p.data.size(); ++k)
           sc.path.push_back(p.in.r.vec3(p.data[k], p.path + "[" + std::to_string(k) + "]"));
       }},
      {"direction",
       [](const Value& d, Scalpel& sc) {
         sc.depth_direction = d.vec3();
         if (!(sc.depth_direction.norm() > 0.0)) d.fail("must not be zero");
       }},
      {"depth_mm", number(&Scalpel::depth_mm, positive, "must be > 0 mm")},
      {"start_s", number(&Scalpel::start_s, non_negative, "must be >= 0")},
      {"end_s",
       [](const Value& e, Scalpel& sc) {
         const double start = sc.start_s;
         sc.end_s = e.number([start](double end) { return end > start; },
                             fmt::format("must be after start_s ({})", start));
       }},
  };
  const Object in = open_object(v.in.r, v.data, v.path, kKeys);
  for (const char* key : {"path", "depth_mm", "end_s"})
    if (!in.has(key))
      in.r.fail(v.path, fmt::format("needs \"{}\" ({})", key,
                                    std::string_view(key) == "path" ? "[[x, y, z], ...] mm"
                                    : std::string_view(key) == "depth_mm"
                                        ? "how deep the blade reaches, mm"
                                        : "when the blade reaches the path's end, s"));
  Scalpel sc;
  read_keys(in, kKeys, sc);
  if (const auto problem = interact::scalpel_problem(sc)) in.fail(problem->first, problem->second);
  s.scalpels.push_back(std::move(sc));
}

void read_tools(const Value& v, Scene& s) {
  static const Keys<Tool> kKeys = {
      {"point",
       [](const Value& p, Tool& t) {
         t.by_point = true;
         t.point_mm = p.vec3();
       }},
      {"vertex", integer(&Tool::vertex, 0, kInt32Max)},
      {"grasp", read_grasp},
      {"force_n",
       [](const Value& f, Tool& t) { t.force_mn = detail::kMilliNewtonsPerNewton * f.vec3(); },
       force_or_drag},
      {"gain_n_per_mm", {}},  // read by drag_mm's row, which it scales
      {"drag_mm",
       [](const Value& d, Tool& t) {
         double gain = 0.05;
         if (d.in.has("gain_n_per_mm"))
           gain = d.in.value("gain_n_per_mm").number(positive, "must be > 0 N/mm");
         t.force_mn = detail::kMilliNewtonsPerNewton * gain * d.vec3();
       }},
      {"start_s", number(&Tool::start_s, non_negative, "must be >= 0")},
      {"radius_mm",
       [](const Value& r, Tool& t) {
         t.radius_mm = t.grasp ? r.number(positive, "must be > 0 mm (skin within it is grasped)")
                               : r.number(non_negative,
                                          "must be >= 0 mm (the patch the force is spread over "
                                          "without routing; 0 = a point)");
       }},
      // A null end means the tool never lets go (the same as leaving the key out).
      {"end_s",
       [](const Value& e, Tool& t) {
         if (e.data.is_null()) return;
         const double start = t.start_s;
         t.end_s = e.number([start](double end) { return end > start; },
                            fmt::format("must be after start_s ({})", start));
       }},
  };
  if (!v.data.is_array())
    v.fail("expected an array of tools [...], got " + Reader::describe(v.data));
  s.default_tool = false;
  for (size_t k = 0; k < v.data.size(); ++k) {
    const std::string path = v.path + "[" + std::to_string(k) + "]";
    if (v.data[k].is_object() && v.data[k].contains("scalpel")) {
      if (v.data[k].size() != 1)
        v.in.r.fail(path, "a scalpel is its own tool: {\"scalpel\": {...}} with nothing beside");
      const Object tool{v.in.r, v.data[k], path};
      read_scalpel(Value{tool, v.data[k]["scalpel"], path + ".scalpel"}, s);
      continue;
    }
    const Object in = open_object(v.in.r, v.data[k], path, kKeys);
    if (in.has("point") == in.has("vertex"))
      in.r.fail(path, in.has("point")
                          ? "give either \"point\" or \"vertex\", not both"
                          : "needs \"point\": [x, y, z] (mm) or \"vertex\": skin node index");
    Tool tool;
    read_keys(in, kKeys, tool);
    s.tools.push_back(tool);
  }
}

// boundary.support[k]: skin held elastically.
void read_support(const Value& v, Scene& s) {
  static const Keys<Support> kKeys = {
      {"direction",
       [](const Value& d, Support& o) {
         o.direction = d.vec3();
         if (!(o.direction.norm() > 0.0)) d.fail("must not be zero");
       }},
      {"max_angle_deg",
       number(
           &Support::max_angle_deg, [](double a) { return a >= 0.0 && a <= 180.0; },
           "must be between 0 and 180 degrees")},
      {"stiffness_kpa_per_mm",
       number(&Support::stiffness_kpa_per_mm, non_negative, "must be >= 0 kPa/mm")},
  };
  if (!v.data.is_array())
    v.fail("expected an array of supported surfaces [...], got " + Reader::describe(v.data));
  for (size_t k = 0; k < v.data.size(); ++k) {
    Support o;
    read_object(v.in.r, v.data[k], v.path + "[" + std::to_string(k) + "]", kKeys, o);
    s.support.push_back(o);
  }
}

// boundary.fixed[k].plane: the nodes near a plane.
void read_plane(const Value& v, FixedRegion& region) {
  static const Keys<FixedRegion> kKeys = {
      {"point", vec3(&FixedRegion::plane_point_mm)},
      {"normal",
       [](const Value& n, FixedRegion& f) {
         f.plane_normal = n.vec3();
         if (!(f.plane_normal.norm() > 0.0)) n.fail("must not be zero");
       }},
      {"distance_mm", number(&FixedRegion::distance_mm, non_negative, "must be >= 0")},
  };
  const Object plane = open_object(v.in.r, v.data, v.path, kKeys);
  region.has_plane = true;
  if (!plane.has("point")) v.fail("needs \"point\": [x, y, z] (mm)");
  if (!plane.has("normal")) v.fail("needs \"normal\": [nx, ny, nz]");
  read_keys(plane, kKeys, region);
}

// boundary.fixed[k]: nodes held at rest.
void read_fixed(const Value& v, Scene& s) {
  static const Keys<FixedRegion> kKeys = {
      {"plane", read_plane},
      {"nodes",
       [](const Value& n, FixedRegion& f) {
         if (!n.data.is_array())
           n.fail("expected an array of node indices, got " + Reader::describe(n.data));
         for (size_t i = 0; i < n.data.size(); ++i)
           f.nodes.push_back(static_cast<int32_t>(
               n.in.r.integer(n.data[i], n.path + "[" + std::to_string(i) + "]", 0, kInt32Max)));
       }},
  };
  if (!v.data.is_array())
    v.fail("expected an array of regions [...], got " + Reader::describe(v.data));
  for (size_t k = 0; k < v.data.size(); ++k) {
    const std::string path = v.path + "[" + std::to_string(k) + "]";
    const Object in = open_object(v.in.r, v.data[k], path, kKeys);
    if (!in.has("plane") && !in.has("nodes"))
      in.r.fail(path, "needs \"plane\": {point, normal, distance_mm} and/or \"nodes\": [indices]");
    FixedRegion region;
    read_keys(in, kKeys, region);
    s.fixed.push_back(std::move(region));
  }
}

void read_boundary(const Value& v, Scene& s) {
  // Support before fixed regions: the order a scene's mistakes there have always been reported in.
  static const Keys<Scene> kKeys = {{"support", read_support}, {"fixed", read_fixed}};
  const Object boundary = open_object(v.in.r, v.data, v.path, kKeys);
  s.default_fixed = false;
  read_keys(boundary, kKeys, s);
}

void read_output(const Value& v, Scene& s) {
  static const Keys<Scene> kKeys = {
      {"frame_interval_s", number(in_output<&SceneOutput::frame_interval_s>, non_negative,
                                  "must be >= 0 (0 = first and final frames only)")},
      {"all_layers", boolean(in_output<&SceneOutput::all_layers>)},
      {"obj", boolean(in_output<&SceneOutput::obj>)},
      {"embedded", boolean(in_output<&SceneOutput::embedded>)},
      {"display_skin", boolean(in_output<&SceneOutput::display_skin>)},
      {"metrics_every_step", boolean(in_output<&SceneOutput::metrics_every_step>)},
  };
  read_object(v.in.r, v.data, v.path, kKeys, s);
}

}  // namespace

namespace detail {

json parse_scene_json(const std::string& json_text, const std::string& source_name) {
  try {
    // Comments are allowed: a scene file is written by hand and worth annotating.
    return json::parse(json_text, nullptr, true, true);
  } catch (const json::exception& e) {
    // "[json.exception.parse_error.101] parse error at line 3, column 5: ...": the bracketed
    // tag means nothing to a person editing the file.
    std::string what = e.what();
    if (!what.empty() && what[0] == '[' && what.find("] ") != std::string::npos)
      what = what.substr(what.find("] ") + 2);
    throw invalid_input(source_name, "invalid JSON: " + what);
  }
}

Scene read_scene_object(const json& doc, const std::string& source_name, const std::string& top) {
  static const Keys<Scene> kKeys = {
      {"model", read_model}, {"material", read_material}, {"solver", read_solver},
      {"tools", read_tools}, {"boundary", read_boundary}, {"output", read_output},
  };
  Scene s;
  s.source = source_name;
  const Reader r(s.source);
  if (!doc.is_object()) {
    if (top.empty())
      throw invalid_input(source_name,
                          "expected a JSON object {...} at the top, got " + Reader::describe(doc));
    r.require_object(doc, top);
  }
  // A world scene read as one organ would be the default scene with its bodies ignored.
  if (top.empty() && doc.contains("bodies"))
    throw invalid_input(source_name,
                        "is a world scene (it has \"bodies\"): `lamina run` or "
                        "lamina.world_scene() runs it; this command drives one organ for now "
                        "(docs/world.md)");
  r.warn_unknown(doc, top, kKeys);
  read_keys(Object{r, doc, top}, kKeys, s);
  // Rings must reach as far as the routing spreads force.
  s.build.locality = std::max(s.build.locality, s.routing.locality);
  return s;
}

interact::Scalpel read_blade(const Reader& r, const json& data, const std::string& path) {
  Scene holder;
  const Object in{r, data, path};
  read_scalpel(Value{in, data, path}, holder);
  return holder.scalpels.front();
}

}  // namespace detail

Scene parse_scene(const std::string& json_text, const std::string& source_name) {
  return detail::read_scene_object(detail::parse_scene_json(json_text, source_name), source_name,
                                   "");
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

}  // namespace lamina::io
