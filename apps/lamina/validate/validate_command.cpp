// `lamina validate`: the mass-spring model against linear and corotational finite elements on
// the same indentations of the same segmentation, and the volume each keeps (docs/validation.md).
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "lamina/core/atomic_file.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/geometry/prepare_mask.h"
#include "lamina/io/scene.h"
#include "lamina/model/identify_springs.h"
#include "lamina/validate/indentation.h"
#include "plots.h"
#include "refinement_report.h"
#include "stability_report.h"

namespace lamina::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// One row of the comparison: a solver's answer to one indentation depth.
struct Row {
  double depth_pct = 0.0, depth_mm = 0.0;
  std::string solver;  // fem_corotational, fem_linear, ms_tets, ms_tet_springs, ms_links, ms_skin
  validate::IndentResult result;
  validate::FieldError error;  // against `reference` at the same depth
  // The FEM solution the error is measured against: corotational, or Neo-Hookean for the
  // Neo-Hookean tetrahedra (the same law: what is left is the model's and the meshes' error).
  std::string reference = "fem_corotational";
};

// The RMS error in % of the reference's largest displacement (0 for the reference itself).
double rms_pct(const validate::FieldError& e) {
  return e.reference_max_mm > 0 ? 100.0 * e.rms_mm / e.reference_max_mm : 0.0;
}

double median_intra_length(const Model& m) {
  std::vector<double> l;
  for (size_t e = 0; e < m.springs.size(); ++e)
    if (m.springs.kind[e] == SpringKind::kIntraLayer) l.push_back(m.springs.rest_length_mm[e]);
  std::nth_element(l.begin(), l.begin() + static_cast<long>(l.size() / 2), l.end());
  return l[l.size() / 2];
}

// A scene without E and nu is validated with the documented liver defaults, damped by the
// default ratio (the paper's gamma belongs to its unit masses, not to physical ones).
void make_elastic(io::Scene& scene) {
  if (scene.elastic) return;
  scene.damping_given = false;
  io::use_elastic_material(scene);
}

std::string csv_of(const std::vector<Row>& rows) {
  std::string csv =
      "depth_pct,depth_mm,solver,force_n,volume_change_pct,rms_error_mm,max_error_mm,"
      "rms_error_pct,max_displacement_mm,converged,steps,seconds,reference\n";
  for (const Row& r : rows)
    csv +=
        fmt::format("{:.4g},{:.6g},{},{:.6g},{:.6g},{:.6g},{:.6g},{:.4g},{:.6g},{},{},{:.3f},{}\n",
                    r.depth_pct, r.depth_mm, r.solver, r.result.force_n, r.result.volume_change_pct,
                    r.error.rms_mm, r.error.max_mm, rms_pct(r.error),
                    r.result.skin_u.rows() ? r.result.skin_u.rowwise().norm().maxCoeff() : 0.0,
                    r.result.converged ? 1 : 0, r.result.steps, r.result.seconds, r.reference);
  return csv;
}

std::string label_of(const std::string& solver) {
  if (solver == "fem_corotational") return "FEM, corotational (reference)";
  if (solver == "fem_linear") return "FEM, linear";
  if (solver == "fem_neo_hookean") return "FEM, stable Neo-Hookean";
  if (solver == "ms_tets") return "tetrahedral springs, coupled, + volume (the physical liver)";
  if (solver == "ms_tet_springs") return "tetrahedral springs, independent, + volume";
  if (solver == "ms_neo_hookean") return "tetrahedra, stable Neo-Hookean";
  if (solver == "fem_sphere") return "FEM pressed by the sphere tool (reference)";
  if (solver == "ms_sphere") return "the sphere tool through the contact code";
  if (solver == "ms_links") return "layers and links (as the paper) + volume term";
  return "mass-spring, skin only";
}

// One mass-spring model the validation runs: its name, model and material.
struct Variant {
  std::string name;
  const Model* model = nullptr;
  sim::Material material;
};

void draw_plots(const fs::path& out, const std::vector<std::string>& solvers,
                const std::vector<double>& depths) {
  const std::string gp = find_gnuplot();
  // Depths from 0 to a little past the deepest (one depth alone would be an empty x range).
  const std::string style =
      std::string(kPlotStyle) + fmt::format("set xrange [0:{}]\n", 1.1 * depths.back());
  const std::string data = quote(out / "validation.csv");
  auto series = [&](const std::string& column, bool skip_reference) {
    std::string s;
    for (const std::string& name : solvers) {
      if (skip_reference && (name == "fem_corotational" || name == "fem_sphere")) continue;
      s += fmt::format(
          "{}{} using 1:(strcol(3) eq '{}' ? {} : NaN) with linespoints title '{}' noenhanced",
          s.empty() ? "plot " : ", \\\n     ", data, name, column, label_of(name));
    }
    return s + "\n";
  };
  draw_plot(gp, out, "force_depth",
            style +
                "set xlabel 'indentation, % of the organ depth'\nset ylabel 'indenter force, N'\n"
                "set key top left box opaque\nset datafile missing NaN\n",
            series("$4", false));
  draw_plot(gp, out, "skin_error",
            style +
                "set xlabel 'indentation, % of the organ depth'\n"
                "set ylabel 'skin displacement RMS error vs corotational FEM, % of its largest'\n"
                "set key top left box opaque\nset datafile missing NaN\n",
            series("$8", true));
  draw_plot(gp, out, "volume_change",
            style +
                "set xlabel 'indentation, % of the organ depth'\nset ylabel '|volume change|, %'\n"
                "set logscale y\nset key top left box opaque\nset datafile missing NaN\n",
            series("(abs($5) > 0 ? abs($5) : NaN)", false));
}

}  // namespace

int run_validate(const ValidateArgs& a) {
  const auto t0 = Clock::now();
  io::Scene scene = io::scene_for(a.what);
  if (!a.refine.empty()) {
    if (a.stability || a.tool_only || a.model_only || a.fem_on_model || a.quick ||
        !a.depths.empty() || !a.cases.empty())
      throw invalid_input("--refine",
                          "runs alone: not with --stability, --case, --tool-only, --model-only, "
                          "--fem-on-model, --quick or --depths");
    if (!scene.model_path.empty())
      throw invalid_input(a.what,
                          "lamina validate --refine builds the organ at several sizes: give the "
                          "mask (or a scene with model.input), not a saved model");
    make_elastic(scene);
    return report_refinement(a, std::move(scene));
  }
  if (!scene.model_path.empty())
    throw invalid_input(a.what,
                        "lamina validate meshes the segmentation for its finite elements: give "
                        "the mask (or a scene with model.input), not a saved model");
  if (!a.cases.empty() && !a.stability)
    throw invalid_input("--case", "chooses among the stability suite's cases: give --stability");
  if (a.model_only && (a.stability || a.tool_only))
    throw invalid_input("--model-only",
                        "compares the scene's own model with finite elements: not with "
                        "--stability or --tool-only");
  if (!a.output.empty()) check_output_folder(a.output);
  make_elastic(scene);
  // A --case that names none is refused before the build. Only the names are checked here: the
  // material (whether projective dynamics' cases are in) is resolved after the build, and the
  // report chooses the cases then.
  if (a.stability) check_stability_case_names(a);
  // The comparison with finite elements presses the simulation's skin (the FEM boundary's
  // match) and draws no picture: a display skin would cost each model build about half a second
  // (the 400-vertex phantom: 1.07 s against 0.61 s) for nothing. The stability suite's tools
  // touch the display skin as `lamina run`'s do, so it keeps it.
  if (!a.stability) scene.build.display_triangles = 0;
  const ProgressFn progress = stderr_progress(a.verbose);

  // 1. The mass-spring models: the scene's (the tetrahedra, unless the scene builds links), its
  //    tetrahedra with independent springs, the paper's layers and links with the volume term,
  //    and a skin-only one, each with its material identified from the same E and nu.
  io::SceneModel built = io::make_scene_model(scene, volume_read_options, progress);
  Model& m = built.model;
  const double edge = median_intra_length(m);
  const double radius =
      a.indenter_radius_mm > 0.0 ? a.indenter_radius_mm : std::max(8.0, 1.6 * edge);
  validate::Indentation ind =
      a.deepest ? validate::deepest_indentation(m, radius) : validate::paper_indentation(m, radius);
  // The tool case needs a volume that carries the load.
  const bool tool = m.has_tets() && !a.model_only;
  const std::vector<int32_t> held =
      sim::nodes_near_plane(m, ind.held_point_mm, ind.held_normal, ind.held_distance_mm);
  const io::Scene parsed = scene;  // before resolve_material() fills in the material
  // The stability suite holds the organ as the scene does besides the slab: by its elastic
  // support (the physical scenes' default, the posterior surface). Without it the suite's tools
  // swung a liver about a 10 mm slab, as no scene holds one (docs/validation.md). The comparison
  // with finite elements holds the slab alone, as its reference is held.
  model::SurfaceSupport support;
  if (a.stability) {
    io::resolve_scene_defaults(scene, m);
    support = io::scene_support(scene, m);
  }
  const io::MaterialReport material = io::resolve_material(scene, m, held, support);
  if (a.stability) return report_stability(a, scene, m, ind, support);
  if (a.tool_only && !tool)
    throw invalid_input(built.source,
                        "--tool-only needs a model with tetrahedra (the sphere's load is carried "
                        "by the volume); this one is built with links");
  // The sphere's contact stiffness: ten times the tissue's E over the radius, so that its
  // penetration is a small part of the dent it makes (both sides use the same value).
  ind.sphere_stiffness_kpa_per_mm = a.sphere_stiffness_kpa_per_mm > 0.0
                                        ? a.sphere_stiffness_kpa_per_mm
                                        : 10.0 * scene.elastic_material.young_modulus_kpa / radius;
  // The same organ and E, nu in the other structures. Their damping does not matter here (every
  // run is taken to rest): the scene's is used throughout.
  auto resolved = [&](io::Scene s, Model& model) {
    s.damping_ratio = -1.0;
    s.damping_given = true;
    s.material.mass_damping_per_s = scene.material.mass_damping_per_s;
    io::resolve_material(
        s, model,
        sim::nodes_near_plane(model, ind.held_point_mm, ind.held_normal, ind.held_distance_mm));
    s.material.mass_damping_per_s = scene.material.mass_damping_per_s;
    return s.material;
  };
  std::vector<Variant> variants;
  if (a.model_only) {
    // The scene's own model and material, named as among the structures.
    const std::string name = !m.has_tets()                                   ? "ms_links"
                             : scene.tet_model == sim::TetModel::kNeoHookean ? "ms_neo_hookean"
                             : scene.tet_elasticity == model::TetElasticity::kSprings
                                 ? "ms_tet_springs"
                                 : "ms_tets";
    variants.push_back({name, &m, scene.material});
  }
  io::Scene links_scene = parsed;
  links_scene.build.structure = model::Structure::kLinks;
  links_scene.tet_model = sim::TetModel::kSprings;  // links have no tetrahedra
  io::Scene skin_scene = links_scene;
  skin_scene.build.layers = 1;
  // Built only when compared (each is a build of the organ).
  io::SceneModel links_built, skin_built;
  if (!a.model_only) {
    links_built = io::make_scene_model(links_scene, volume_read_options, {});
    skin_built = io::make_scene_model(skin_scene, volume_read_options, {});
  }
  if (m.has_tets() && !a.model_only) {
    // The scene's own tetrahedral energy keeps its resolved material; the others are resolved
    // from the same E and nu.
    const auto with_model = [&](sim::TetModel tm, model::TetElasticity te) {
      if (scene.tet_model == tm && scene.tet_elasticity == te) return scene.material;
      io::Scene s = parsed;
      s.tet_model = tm;
      s.tet_elasticity = te;
      return resolved(s, m);
    };
    variants.push_back(
        {"ms_tets", &m, with_model(sim::TetModel::kSprings, model::TetElasticity::kCoupled)});
    variants.push_back({"ms_tet_springs", &m,
                        with_model(sim::TetModel::kSprings, model::TetElasticity::kSprings)});
    variants.push_back({"ms_neo_hookean", &m,
                        with_model(sim::TetModel::kNeoHookean, model::TetElasticity::kCoupled)});
  }
  if (!a.model_only) {
    variants.push_back({"ms_links", &links_built.model, resolved(links_scene, links_built.model)});
    sim::Material skin_material = resolved(skin_scene, skin_built.model);
    skin_material.volume_stiffness_kpa = 0.0;  // a shell has no volume between layers to keep
    variants.push_back({"ms_skin", &skin_built.model, skin_material});
  }
  log::info(
      "validate: {} ({} nodes, {} layers), indenter radius {:.1f} mm at ({:.1f}, {:.1f}, "
      "{:.1f}) mm, organ depth {:.1f} mm along +y",
      built.source, m.node_count(), m.layer_count(), ind.radius_mm, ind.contact_mm.x(),
      ind.contact_mm.y(), ind.contact_mm.z(), ind.organ_depth_mm);

  // 2. The finite-element mesh of the same mask, cells about the springs' length (0.7 of it gave
  //    37k tets on the phantom, whose corotational solves took minutes with a sparse LDLT).
  const LabelVolume volume = read_input(scene.input);
  const geometry::PreparedMask prepared =
      geometry::prepare_mask(volume, {.label = scene.build.label});
  const auto t_mesh = Clock::now();
  // What the run is waiting for, with the time spent so far: the longest stages (the mesh, a
  // corotational solve, a run to rest) each take tens of seconds on a clinical mask.
  const auto elapsed = [&] {
    return fmt::format("{:.0f} s", std::chrono::duration<double>(Clock::now() - t0).count());
  };
  report_progress(
      progress,
      fmt::format("meshing the finite-element reference (CGAL Mesh_3, {:.1f} mm cells), "
                  "{} so far",
                  edge, elapsed()),
      0.0);
  validate::TetMesh mesh = validate::mesh_mask_tets(prepared.mask, {.cell_size_mm = edge});
  if (a.fem_on_model) {
    if (!m.has_tets())
      throw invalid_input("--fem-on-model", "the model has no tetrahedra (built with links)");
    mesh = {m.X, m.tets.T};
  }
  log::info("validate: finite-element mesh {} vertices, {} tets ({:.1f} s)", mesh.V.rows(),
            mesh.T.rows(), std::chrono::duration<double>(Clock::now() - t_mesh).count());

  // 3. Each depth, each solver. Quasi-static mass-spring runs: implicit Euler to a tight rest.
  std::vector<double> depths =
      a.quick ? std::vector<double>{10.0} : std::vector<double>{5.0, 10.0, 20.0, 30.0};
  if (!a.depths.empty()) {
    depths = a.depths;
    std::sort(depths.begin(), depths.end());
  }
  sim::SolverOptions solver = scene.solver;
  solver.integrator = sim::Integrator::kImplicitEuler;
  solver.rest_speed_mm_per_s = 0.01;
  solver.max_steps = 20000;
  // The tool case steps at the haptic rate: its contact is explicit (recomputed each step on
  // the current skin), and at 1 ms the model's masses keep the penalty's stiffness stable.
  sim::SolverOptions press_solver = solver;
  press_solver.dt_s = std::min(solver.dt_s, 0.001);
  press_solver.max_steps = 60000;
  // Large indentations invert elements near the tip unless the load comes on gradually.
  const validate::FemOptions fem_options{.load_steps = 20, .max_newton_iterations = 50};
  const validate::FemMaterial fem_material{scene.elastic_material.young_modulus_kpa,
                                           scene.elastic_material.poisson_ratio};
  // The sphere's tangent takes the turn of its normal in only near the answer (far from it,
  // its indefinite part can carry the skin through the sphere), so Newton ends linearly:
  // 1e-4 of the largest force, far below the percent the comparison reads, and more
  // iterations a step than the tissue alone needs.
  validate::FemOptions press_options = fem_options;
  press_options.tolerance = 1e-4;
  press_options.max_newton_iterations = 100;
  // A frictionless sphere lets the organ slide and swing about a thin held slab, and the swing
  // (tens of mm on a liver, at a force of 0.02-0.1 N) is not what the tool case is after: it
  // holds the posterior half of the organ's depth, so that the sphere dents it.
  validate::Indentation press_ind = ind;
  press_ind.held_distance_mm = std::max(ind.held_distance_mm, 0.5 * ind.organ_depth_mm);
  std::vector<Row> rows;
  // Progress: the mesh counts as one job, then each solver at each depth.
  // The Neo-Hookean tetrahedra and their own FEM reference (with --model-only, for such a model).
  const bool neo = m.has_tets() && (!a.model_only || scene.tet_model == sim::TetModel::kNeoHookean);
  const bool patch = !a.tool_only;
  const double jobs =
      1.0 + static_cast<double>(depths.size() *
                                ((patch ? (neo ? 3 : 2) + variants.size() : 0) + (tool ? 2 : 0)));
  double job = 1.0;
  const auto next = [&](double pct, const std::string& what) {
    report_progress(progress,
                    fmt::format("{:.0f}% indentation: {}, {} so far", pct, what, elapsed()),
                    job++ / jobs);
  };
  for (double pct : depths) {
    const double d = pct / 100.0 * ind.organ_depth_mm;
    const Eigen::MatrixX3d samples = m.X.middleRows(m.layers[0].first_node, m.layers[0].node_count);
    if (tool) {
      // The tool case: the scene's own model pressed by the sphere through the contact code,
      // against FEM of the same tissue law pressed by the same sphere law.
      const bool nh = scene.tet_model == sim::TetModel::kNeoHookean;
      next(pct, fmt::format("{} FEM pressed by the sphere", nh ? "Neo-Hookean" : "corotational"));
      Row fem{
          pct,
          d,
          "fem_sphere",
          validate::press_fem(mesh, fem_material, press_ind, d,
                              nh ? validate::FemLaw::kNeoHookean : validate::FemLaw::kCorotational,
                              samples, press_options),
          {}};
      fem.error.reference_max_mm = fem.result.skin_u.rowwise().norm().maxCoeff();
      fem.reference = "fem_sphere";
      next(pct, fmt::format("the sphere tool on the model ({} nodes) run to rest", m.node_count()));
      Row ms{pct,
             d,
             "ms_sphere",
             validate::press_mass_spring(m, scene.material, press_solver, press_ind, d),
             {}};
      ms.error = validate::field_error(ms.result.skin_u, fem.result.skin_u);
      ms.reference = "fem_sphere";
      rows.push_back(fem);
      rows.push_back(ms);
    }
    if (!patch) continue;
    next(pct, fmt::format("corotational FEM on {} tets, {} load steps", mesh.T.rows(),
                          fem_options.load_steps));
    Row co{pct,
           d,
           "fem_corotational",
           validate::indent_fem(mesh, fem_material, ind, d, validate::FemLaw::kCorotational,
                                samples, fem_options),
           {}};
    co.error.reference_max_mm = co.result.skin_u.rowwise().norm().maxCoeff();
    next(pct, "linear FEM");
    Row li{pct,
           d,
           "fem_linear",
           validate::indent_fem(mesh, fem_material, ind, d, validate::FemLaw::kLinear, samples),
           {}};
    li.error = validate::field_error(li.result.skin_u, co.result.skin_u);
    rows.push_back(co);
    rows.push_back(li);
    Row nh{pct, d, "fem_neo_hookean", {}, {}};
    if (neo) {
      next(pct, fmt::format("Neo-Hookean FEM on {} tets, {} load steps", mesh.T.rows(),
                            fem_options.load_steps));
      nh.result = validate::indent_fem(mesh, fem_material, ind, d, validate::FemLaw::kNeoHookean,
                                       samples, fem_options);
      nh.error = validate::field_error(nh.result.skin_u, co.result.skin_u);
      rows.push_back(nh);
    }
    for (const Variant& v : variants) {
      // Each model's skin has its own nodes: the reference is sampled at them.
      const ModelLayer& skin = v.model->layers[0];
      const Eigen::MatrixX3d at = v.model->X.middleRows(skin.first_node, skin.node_count);
      const Row& ref = v.name == "ms_neo_hookean" ? nh : co;
      const Eigen::MatrixX3d reference =
          v.model == &m ? ref.result.skin_u : validate::sample_on_boundary(mesh, ref.result.u, at);
      next(pct, fmt::format("{} ({} nodes) run to rest", v.name, v.model->node_count()));
      Row r{pct, d, v.name, validate::indent_mass_spring(*v.model, v.material, solver, ind, d), {}};
      r.error = validate::field_error(r.result.skin_u, reference);
      r.reference = ref.solver;
      rows.push_back(r);
    }
  }
  report_progress(progress, "done", 1.0);

  // 4. Report.
  nlohmann::ordered_json j;
  j["input"] = built.source;
  j["young_modulus_kpa"] = scene.elastic_material.young_modulus_kpa;
  j["poisson_ratio"] = scene.elastic_material.poisson_ratio;
  j["structure"] = material.tets ? "tets" : "links";
  j["tets"] = m.tets.size();
  j["nodes"] = m.node_count();
  j["layers"] = m.layer_count();
  j["fem_vertices"] = mesh.V.rows();
  j["fem_tets"] = mesh.T.rows();
  j["contact_mm"] = {ind.contact_mm.x(), ind.contact_mm.y(), ind.contact_mm.z()};
  j["organ_depth_mm"] = ind.organ_depth_mm;
  j["indenter_radius_mm"] = ind.radius_mm;
  if (tool) {
    j["sphere_stiffness_kpa_per_mm"] = ind.sphere_stiffness_kpa_per_mm;
    j["sphere_held_distance_mm"] = press_ind.held_distance_mm;
  }
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (const Row& r : rows) {
    nlohmann::ordered_json o;
    o["depth_pct"] = r.depth_pct;
    o["depth_mm"] = r.depth_mm;
    o["solver"] = r.solver;
    o["force_n"] = r.result.force_n;
    o["volume_change_pct"] = r.result.volume_change_pct;
    o["rms_error_mm"] = r.error.rms_mm;
    o["max_error_mm"] = r.error.max_mm;
    o["rms_error_pct"] = rms_pct(r.error);
    o["converged"] = r.result.converged;
    o["seconds"] = r.result.seconds;
    o["reference"] = r.reference;
    list.push_back(o);
  }
  j["rows"] = list;
  j["wall_seconds"] = std::chrono::duration<double>(Clock::now() - t0).count();

  fmt::print(stderr, "{:>6} {:>17} {:>9} {:>11} {:>10} {:>9} {:>5}\n", "depth", "solver", "force N",
             "volume %", "RMS err %", "max err", "conv");
  for (const Row& r : rows)
    fmt::print(stderr, "{:>5.0f}% {:>17} {:>9.4f} {:>11.4f} {:>10.2f} {:>7.2f}mm {:>5}\n",
               r.depth_pct, r.solver, r.result.force_n, r.result.volume_change_pct,
               rms_pct(r.error), r.error.max_mm, r.result.converged ? "yes" : "NO");
  if (!a.output.empty()) {
    const fs::path out = a.output;
    create_folder(out);
    write_text(out / "validation.csv", csv_of(rows));
    write_text(out / "summary.json", j.dump(2) + "\n");
    std::vector<std::string> solvers;
    if (patch) {
      solvers = {"fem_corotational", "fem_linear"};
      if (neo) solvers.push_back("fem_neo_hookean");
      for (const Variant& v : variants) solvers.push_back(v.name);
    }
    if (tool) solvers.insert(solvers.end(), {"fem_sphere", "ms_sphere"});
    draw_plots(out, solvers, depths);
    log::info(
        "wrote {}: validation.csv, summary.json, force_depth.png, skin_error.png, "
        "volume_change.png",
        out.string());
  }
  if (a.json) std::cout << j.dump(2) << "\n";
  return 0;
}

}  // namespace lamina::cli
