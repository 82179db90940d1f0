// `lamina validate --refine`: is the tool's dent a property of the organ or of the mesh? The
// same organ built at several sizes, each pressed by the same held push on the same display
// skin (so the load is the same at every size), run to rest.
#include "refinement_report.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/geometry/mesh_measures.h"
#include "lamina/interact/tools.h"
#include "lamina/io/scene_model.h"
#include "lamina/model/summarize_model.h"
#include "lamina/validate/indentation.h"
#include "plots.h"

namespace lamina::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// The push: the default poke's 0.4 N.
constexpr double kPushMn = 400.0;
// Quasi-static: implicit Euler at 10 ms (the rest it reaches does not depend on dt), to a rest
// of 0.01 mm/s, within a budget no run at rest needs (the dent at 80k nodes rests in ~150).
constexpr double kStepS = 0.01, kRestSpeedMmPerS = 0.01;
constexpr int64_t kMaxSteps = 5000;
// "Within 10% of the finest": the bound (issue 64).
constexpr double kWithinPct = 10.0;

struct Size {
  int32_t skin_vertices = 0;  // asked for
  int32_t nodes = 0, skin_nodes = 0;
  int64_t tets = 0;
  double skin_edge_mm = 0.0;  // the skin triangles' mean edge: the mesh against the patch
  double dent_mm = 0.0;       // the largest node displacement at rest under the push
  double load_dent_mm = 0.0;  // f . u / |f|: the displacement the load does its work on
  bool rested = false;
  int64_t steps = 0;
  double build_s = 0.0, solve_s = 0.0;
};

double pct_off(double value, double reference) {
  return reference > 0.0 ? 100.0 * (value / reference - 1.0) : 0.0;
}

// The centre dent of an elastic half-space under the tools' pressure p0 (1 - (d/a)^2) over a
// disc of radius a with total force F (p0 = 2F / (pi a^2)): Boussinesq's w(0) = 2 (1 - nu^2) / E
// times the integral of p over the radius, = 8 (1 - nu^2) F / (3 pi E a). kPa = mN/mm^2.
double half_space_dent_mm(double force_mn, double radius_mm, double e_kpa, double nu) {
  return 8.0 * (1.0 - nu * nu) * force_mn / (3.0 * std::numbers::pi * e_kpa * radius_mm);
}

// The smallest size from which every size is within kWithinPct of the finest, by `dent`.
template <class Dent>
std::optional<size_t> within_from(const std::vector<Size>& sizes, Dent dent) {
  std::optional<size_t> from;
  for (size_t k = sizes.size(); k-- > 0;) {
    if (std::abs(pct_off(dent(sizes[k]), dent(sizes.back()))) > kWithinPct) break;
    from = k;
  }
  return from;
}

Size press(const io::Scene& scene, int32_t skin_vertices, Eigen::Vector3d& contact,
           Eigen::Vector3d& direction, double radius_mm, bool deepest) {
  Size r;
  r.skin_vertices = skin_vertices;
  io::Scene at = scene;
  at.build.skin_vertices = skin_vertices;
  const auto t0 = Clock::now();
  const io::ReadyScene ready = io::make_ready_scene(at, volume_read_options);
  r.build_s = std::chrono::duration<double>(Clock::now() - t0).count();
  const Model& m = *ready.model;
  if (!contact.allFinite()) {  // the coarsest model places the push for every size
    const validate::Indentation ind = deepest ? validate::deepest_indentation(m, radius_mm)
                                              : validate::paper_indentation(m, radius_mm);
    contact = ind.contact_mm;
    direction = ind.direction.normalized();
  }
  const auto t1 = Clock::now();
  sim::Simulation s = io::make_scene_simulation(ready);
  interact::ToolDriver driver = io::make_tool_driver(ready.scene, /*warn_scalpels=*/false);
  driver.tools = {{.by_point = true,
                   .point_mm = contact,
                   .force_mn = kPushMn * direction,
                   .radius_mm = radius_mm}};
  sim::RestStreak rest{.needed = sim::quiet_steps(s)};
  for (; r.steps < kMaxSteps && !r.rested; ++r.steps) {
    interact::apply_tools(s, driver);
    const sim::StepStats st = sim::step(s);
    if (st.unstable != sim::Instability::kNone || !s.x.allFinite())
      throw Error(ErrorKind::kUnstable,
                  fmt::format("validate --refine: the model at {} skin vertices blew up under "
                              "the push after {} steps ({})",
                              skin_vertices, r.steps + 1, sim::describe(st.unstable)));
    r.rested = rest.update(st);
  }
  r.solve_s = std::chrono::duration<double>(Clock::now() - t1).count();
  const Eigen::MatrixX3d u = s.x - m.X;
  r.dent_mm = u.rowwise().norm().maxCoeff();
  const double force = s.f_ext.colwise().sum().norm();
  r.load_dent_mm = force > 0.0 ? (s.f_ext.array() * u.array()).sum() / force : 0.0;
  r.nodes = m.node_count();
  r.skin_nodes = m.layers[0].node_count;
  r.tets = m.tets.size();
  r.skin_edge_mm = geometry::measure_mesh(model::layer_mesh(m, 0)).mean_edge_mm;
  return r;
}

std::string csv_of(const std::vector<Size>& sizes) {
  std::string csv =
      "skin_vertices,nodes,tets,skin_edge_mm,dent_mm,dent_vs_finest_pct,load_dent_mm,load_dent_vs_"
      "finest_pct,"
      "rested,steps,build_s,solve_s\n";
  const Size& fine = sizes.back();
  for (const Size& r : sizes)
    csv += fmt::format("{},{},{},{:.4g},{:.6g},{:.4g},{:.6g},{:.4g},{},{},{:.3f},{:.3f}\n",
                       r.skin_vertices, r.nodes, r.tets, r.skin_edge_mm, r.dent_mm,
                       pct_off(r.dent_mm, fine.dent_mm), r.load_dent_mm,
                       pct_off(r.load_dent_mm, fine.load_dent_mm), r.rested ? 1 : 0, r.steps,
                       r.build_s, r.solve_s);
  return csv;
}

void draw(const fs::path& out, double half_space_mm) {
  const std::string data = quote(out / "refinement.csv");
  draw_plot(find_gnuplot(), out, "refinement",
            std::string(kPlotStyle) +
                "set xlabel 'nodes'\nset ylabel 'dent under the held push, mm'\nset logscale x\n"
                "set key bottom right box opaque\nset yrange [0:*]\n",
            fmt::format("plot {0} using 2:5 with linespoints title 'largest displacement', \\\n"
                        "     {0} using 2:7 with linespoints title 'under the load (f.u/|f|)', "
                        "\\\n     {1:.6g} with lines dashtype 2 title 'elastic half-space, "
                        "centre (Boussinesq)'\n",
                        data, half_space_mm));
}

}  // namespace

int report_refinement(const ValidateArgs& a, io::Scene scene) {
  const auto t0 = Clock::now();
  std::vector<int32_t> sizes = a.refine;
  std::sort(sizes.begin(), sizes.end());
  sizes.erase(std::unique(sizes.begin(), sizes.end()), sizes.end());
  if (sizes.size() < 2)
    throw invalid_input("--refine", "give at least two skin sizes, e.g. 1284,5000,20000");
  if (!a.output.empty()) check_output_folder(a.output);
  // The refinement's own push replaces the scene's tools; the rest at any dt is the same.
  scene.tools.clear();
  scene.default_tool = false;
  scene.solver.integrator = sim::Integrator::kImplicitEuler;
  scene.solver.dt_s = std::max(scene.solver.dt_s, kStepS);
  scene.solver.rest_speed_mm_per_s = kRestSpeedMmPerS;
  const double radius =
      a.indenter_radius_mm > 0.0 ? a.indenter_radius_mm : interact::kDefaultPatchRadiusMm;
  const ProgressFn progress = stderr_progress(a.verbose);
  Eigen::Vector3d contact = Eigen::Vector3d::Constant(std::nan("")), direction;
  std::vector<Size> rows;
  for (size_t k = 0; k < sizes.size(); ++k) {
    report_progress(progress,
                    fmt::format("refinement: {} skin vertices ({} of {}), built and pressed to "
                                "rest, {:.0f} s so far",
                                sizes[k], k + 1, sizes.size(),
                                std::chrono::duration<double>(Clock::now() - t0).count()),
                    static_cast<double>(k) / static_cast<double>(sizes.size()));
    rows.push_back(press(scene, sizes[k], contact, direction, radius, a.deepest));
    log::info("validate --refine: {} nodes, dent {:.3f} mm ({} steps{})", rows.back().nodes,
              rows.back().dent_mm, rows.back().steps, rows.back().rested ? "" : ", not at rest");
  }
  report_progress(progress, "done", 1.0);

  const model::ElasticMaterial& mat = scene.elastic_material;
  const double half_space =
      half_space_dent_mm(kPushMn, radius, mat.young_modulus_kpa, mat.poisson_ratio);
  const auto by_dent = within_from(rows, [](const Size& r) { return r.dent_mm; });
  const auto by_load = within_from(rows, [](const Size& r) { return r.load_dent_mm; });
  const Size& fine = rows.back();

  nlohmann::ordered_json j;
  j["input"] = scene.input;
  j["young_modulus_kpa"] = mat.young_modulus_kpa;
  j["poisson_ratio"] = mat.poisson_ratio;
  j["force_n"] = kPushMn / 1000.0;
  j["radius_mm"] = radius;
  j["contact_mm"] = {contact.x(), contact.y(), contact.z()};
  j["direction"] = {direction.x(), direction.y(), direction.z()};
  j["half_space_dent_mm"] = half_space;
  j["within_pct"] = kWithinPct;
  j["within_from_nodes"] = by_dent ? nlohmann::ordered_json(rows[*by_dent].nodes) : nullptr;
  j["load_dent_within_from_nodes"] =
      by_load ? nlohmann::ordered_json(rows[*by_load].nodes) : nullptr;
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (const Size& r : rows)
    list.push_back({{"skin_vertices", r.skin_vertices},
                    {"nodes", r.nodes},
                    {"skin_nodes", r.skin_nodes},
                    {"tets", r.tets},
                    {"skin_edge_mm", r.skin_edge_mm},
                    {"dent_mm", r.dent_mm},
                    {"dent_vs_finest_pct", pct_off(r.dent_mm, fine.dent_mm)},
                    {"dent_vs_half_space_pct", pct_off(r.dent_mm, half_space)},
                    {"load_dent_mm", r.load_dent_mm},
                    {"load_dent_vs_finest_pct", pct_off(r.load_dent_mm, fine.load_dent_mm)},
                    {"rested", r.rested},
                    {"steps", r.steps},
                    {"build_seconds", r.build_s},
                    {"solve_seconds", r.solve_s}});
  j["rows"] = list;
  j["wall_seconds"] = std::chrono::duration<double>(Clock::now() - t0).count();

  fmt::print(stderr,
             "0.4 N over {:.1f} mm at ({:.1f}, {:.1f}, {:.1f}) mm, held to rest; elastic "
             "half-space (Boussinesq): {:.2f} mm at the centre\n",
             radius, contact.x(), contact.y(), contact.z(), half_space);
  fmt::print(stderr, "{:>8} {:>8} {:>9} {:>8} {:>9} {:>8} {:>11} {:>8} {:>5}\n", "skin", "nodes",
             "tets", "edge mm", "dent mm", "finest", "f.u/|f| mm", "finest", "rest");
  for (const Size& r : rows)
    fmt::print(stderr,
               "{:>8} {:>8} {:>9} {:>8.2f} {:>9.3f} {:>+7.1f}% {:>11.3f} {:>+7.1f}% {:>5}\n",
               r.skin_vertices, r.nodes, r.tets, r.skin_edge_mm, r.dent_mm,
               pct_off(r.dent_mm, fine.dent_mm), r.load_dent_mm,
               pct_off(r.load_dent_mm, fine.load_dent_mm), r.rested ? "yes" : "NO");
  fmt::print(stderr, "within {:.0f}% of the finest: {}\n", kWithinPct,
             by_dent ? fmt::format("from {} nodes on", rows[*by_dent].nodes)
                     : std::string("only the finest itself"));
  if (!a.output.empty()) {
    const fs::path out = a.output;
    create_folder(out);
    write_text(out / "refinement.csv", csv_of(rows));
    write_text(out / "summary.json", j.dump(2) + "\n");
    draw(out, half_space);
    log::info("wrote {}: refinement.csv, summary.json, refinement.png", out.string());
  }
  if (a.json) std::cout << j.dump(2) << "\n";
  // A size that never came to rest is a dent not measured: the run says so by its exit.
  for (const Size& r : rows)
    if (!r.rested)
      throw Error(ErrorKind::kUnstable,
                  fmt::format("validate --refine: the model at {} skin vertices did not come "
                              "to rest within {} steps: its dent is not measured",
                              r.skin_vertices, kMaxSteps));
  return 0;
}

}  // namespace lamina::cli
