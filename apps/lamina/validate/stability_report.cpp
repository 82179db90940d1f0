// `lamina validate --stability`: large loads, releases and time-step sweeps, each checked for
// finite states, layer order, decaying energy and the return to rest.
#include "stability_report.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <exception>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/validate/stability.h"
#include "plots.h"

namespace lamina::cli {
namespace {

namespace fs = std::filesystem;
using validate::StabilityResult;

std::string kind_name(validate::LoadKind k) {
  switch (k) {
    case validate::LoadKind::kIndent:
      return "indent";
    case validate::LoadKind::kPull:
      return "pull";
    case validate::LoadKind::kTools:
      return "tools";
  }
  return "";
}

std::string csv_of(const std::vector<StabilityResult>& rows, const validate::StabilityOptions& o) {
  std::string csv =
      "case,kind,integrator,dt_s,passed,finite,recoveries,outside_nodes,surfaces_cross,"
      "inverted_tets,peak_displacement_mm,peak_volume_change_pct,loaded_at_rest,energy_rise,final_"
      "energy_ratio,"
      "returned_at_rest,rest_error_mm,steps,seconds\n";
  for (const StabilityResult& r : rows) {
    const double e0 = r.release_energy_j > 0 ? r.release_energy_j : 1.0;  // the final ratio's
    csv += fmt::format(
        "{},{},{},{:g},{},{},{},{},{},{},{:.6g},{:.6g},{},{:.6g},{:.6g},{},{:.6g},{},{:.3f}\n",
        r.c.name, kind_name(r.c.kind), io::integrator_name(r.c.integrator), r.c.dt_s,
        r.passed(o) ? 1 : 0, r.finite ? 1 : 0, r.recoveries, r.order.outside_nodes,
        r.order.surfaces_cross ? 1 : 0, r.order.inverted_tets, r.peak_displacement_mm,
        r.peak_volume_change_pct, r.loaded_at_rest ? 1 : 0, r.energy_rise(), r.final_energy_j / e0,
        r.returned_at_rest ? 1 : 0, r.rest_error_mm, r.steps, r.seconds);
  }
  return csv;
}

// The energy after each release relative to its value at the release, at most ~300 samples a
// case (a run at a small dt has thousands of steps).
std::string energy_csv_of(const std::vector<StabilityResult>& rows) {
  std::string csv = "case,integrator,dt_s,t_s,energy_j,relative_energy\n";
  for (const StabilityResult& r : rows) {
    if (r.energy_trace.empty() || r.release_energy_j <= 0) continue;
    const size_t every = std::max<size_t>(1, r.energy_trace.size() / 300);
    for (size_t k = 0; k < r.energy_trace.size(); k += every) {
      const auto& [t, e] = r.energy_trace[k];
      csv +=
          fmt::format("{},{},{:g},{:.6g},{:.6g},{:.6g}\n", r.c.name,
                      io::integrator_name(r.c.integrator), r.c.dt_s, t, e, e / r.release_energy_j);
    }
  }
  return csv;
}

void draw_plots(const fs::path& out, const std::vector<StabilityResult>& rows, double base_dt,
                const validate::StabilityOptions& options) {
  const std::string gp = find_gnuplot();
  const std::string energy = quote(out / "stability_energy.csv");
  // Energy decay of the load cases at the scene's dt (the dt sweep would crowd the picture).
  std::string body;
  int series = 0;
  for (const StabilityResult& r : rows) {
    if (r.c.dt_s != base_dt || r.c.integrator != sim::Integrator::kImplicitEuler) continue;
    // gnuplot cycles 8 colours: the next eight are dashed.
    body += fmt::format(
        "{}{} using 4:(strcol(1) eq '{}' && strcol(2) eq 'implicit_euler' && $3 == {:g} && $6 > 0 "
        "? $6 : NaN) with lines lw 2 dt {} title '{}' noenhanced",
        body.empty() ? "plot " : ", \\\n     ", energy, r.c.name, base_dt, 1 + series++ / 8,
        r.c.name);
  }
  draw_plot(gp, out, "stability_energy",
            std::string(kPlotStyle) +
                "set xlabel 'time after the release, s'\n"
                "set ylabel 'energy / energy at the release'\nset logscale y\n"
                "set key top right box opaque\nset datafile missing NaN\n",
            body + "\n");
  // The dt sweep: steps to load and return to rest against dt, per integrator.
  const std::string data = quote(out / "stability.csv");
  std::string sweep;
  for (sim::Integrator in : {sim::Integrator::kSemiImplicitEuler, sim::Integrator::kImplicitEuler,
                             sim::Integrator::kProjective}) {
    const std::string name = io::integrator_name(in);
    const auto swept = [&](const StabilityResult& r) {
      return r.c.integrator == in && r.c.name == "indent 30%";
    };
    if (std::none_of(rows.begin(), rows.end(), swept)) continue;  // --quick sweeps two of three
    sweep += fmt::format(
        "{}{} using 4:(strcol(3) eq '{}' && strcol(1) eq 'indent 30%' ? $17 : NaN) with "
        "linespoints lw 2 title '{}' noenhanced",
        sweep.empty() ? "plot " : ", \\\n     ", data, name, name);
    const bool failed = std::any_of(rows.begin(), rows.end(), [&](const StabilityResult& r) {
      return swept(r) && !r.passed(options);
    });
    if (failed)  // a series with no point would only make gnuplot warn
      sweep += fmt::format(
          ", \\\n     {} using 4:(strcol(3) eq '{}' && strcol(1) eq 'indent 30%' && $5 == 0 ? "
          "$17 : NaN) with points pt 6 ps 3 lc 'red' notitle",
          data, name);
  }
  draw_plot(
      gp, out, "stability_dt",
      std::string(kPlotStyle) +
          "set xlabel 'time step dt, s'\nset ylabel 'steps to load (30% indentation) and "
          "return to rest (substeps not counted)'\nset logscale xy\nset key top right box opaque\n"
          "set datafile missing NaN\nset label 1 'red ring: a check failed' at graph "
          "0.02, graph 0.05\n",
      sweep + "\n");
}

}  // namespace

// The dt the sweep scales: the paper's step.
constexpr double kStabilityBaseDt = 0.01;

namespace {

// A case is its name then its integrator ("indent 30% semi_implicit_euler"), so that the dt
// sweep's cases of one name can be told apart ("indent 30% implicit": implicit Euler's).
bool names_case(const std::string& want, const validate::StabilityCase& c) {
  return (c.name + " " + io::integrator_name(c.integrator)).find(want) != std::string::npos;
}

// Refuses each of a.cases that names none of `all`, listing their names.
void check_case_names(const ValidateArgs& a, const std::vector<validate::StabilityCase>& all) {
  for (const std::string& want : a.cases) {
    if (std::any_of(all.begin(), all.end(),
                    [&](const validate::StabilityCase& c) { return names_case(want, c); }))
      continue;
    std::vector<std::string> names;
    for (const validate::StabilityCase& c : all)
      if (std::find(names.begin(), names.end(), c.name) == names.end()) names.push_back(c.name);
    throw invalid_input("--case",
                        fmt::format("no {}stability case is named like \"{}\" (they "
                                    "are: {}; each then its integrator)",
                                    a.quick ? "quick " : "", want, fmt::join(names, ", ")));
  }
}

}  // namespace

void check_stability_case_names(const ValidateArgs& a) {
  // Before the material is resolved: a case of the suite with or without projective dynamics.
  std::vector<validate::StabilityCase> all =
      validate::stability_cases(kStabilityBaseDt, a.quick, true);
  const std::vector<validate::StabilityCase> without =
      validate::stability_cases(kStabilityBaseDt, a.quick, false);
  all.insert(all.end(), without.begin(), without.end());
  check_case_names(a, all);
}

std::vector<validate::StabilityCase> chosen_stability_cases(const ValidateArgs& a,
                                                            const io::Scene& scene) {
  // The sweep is about the paper's step (0.01 s): 1 ms to 0.1 s, the haptic loop's step among
  // them. Projective dynamics does not carry the tetrahedra's elasticity.
  std::vector<validate::StabilityCase> all =
      validate::stability_cases(kStabilityBaseDt, a.quick, scene.material.young_modulus_kpa == 0.0);
  if (a.cases.empty()) return all;
  check_case_names(a, all);
  std::vector<validate::StabilityCase> chosen;
  for (const std::string& want : a.cases)
    for (const validate::StabilityCase& c : all)
      if (names_case(want, c) && std::none_of(chosen.begin(), chosen.end(), [&](const auto& k) {
            return k.name == c.name && k.integrator == c.integrator && k.dt_s == c.dt_s;
          }))
        chosen.push_back(c);
  return chosen;
}

int report_stability(const ValidateArgs& a, const io::Scene& scene, const Model& m,
                     const validate::Indentation& ind, const model::SurfaceSupport& support) {
  const ProgressFn progress = stderr_progress(a.verbose);
  const validate::StabilityOptions options;
  const double dt = kStabilityBaseDt;
  const std::vector<validate::StabilityCase> cases = chosen_stability_cases(a, scene);
  // The cases are independent: one per core at a time, each on one thread (a ~2,000-node model
  // is below the step's parallel threshold anyway, and two OpenMP teams would oversubscribe two
  // cores); fewer cases than cores share the cores out (one case at 43k nodes, `--case`, runs on
  // both). A case's result does not depend on its thread count (SameResultOnOneAndTwoThreads).
  std::vector<StabilityResult> rows(cases.size());
  const auto t0 = std::chrono::steady_clock::now();
  const unsigned workers =
      std::max(1u, std::min<unsigned>(static_cast<unsigned>(omp_get_num_procs()),
                                      static_cast<unsigned>(cases.size())));
  // Longest first, so the two cores finish together: semi-implicit Euler on a physical
  // material runs as substeps below its (conservative) limit, several times an implicit case's
  // time (45-47 s against 5-13 s on a clinical liver).
  std::vector<size_t> order(cases.size());
  for (size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_partition(order.begin(), order.end(), [&](size_t k) {
    return cases[k].integrator == sim::Integrator::kSemiImplicitEuler;
  });
  const int caller_threads = omp_get_max_threads();  // the user's OMP_NUM_THREADS, if set
  const int threads_each =
      std::max(1, std::min(caller_threads, omp_get_num_procs()) / static_cast<int>(workers));
  std::atomic<size_t> next{0};
  size_t done = 0;
  std::mutex report;
  std::exception_ptr failure;
  auto work = [&] {
    omp_set_num_threads(threads_each);
    for (size_t q = next++; q < cases.size(); q = next++) {
      const size_t k = order[q];
      const validate::StabilityCase& c = cases[k];
      try {
        rows[k] =
            validate::run_stability_case(m, scene.material, scene.solver, ind, c, options, support);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(report);
        if (!failure) failure = std::current_exception();
        next = cases.size();
        return;
      }
      const std::lock_guard<std::mutex> lock(report);
      ++done;
      report_progress(
          progress,
          fmt::format("{} of {} cases done ({}, {}, dt {:g} s), {:.0f} s so far", done,
                      cases.size(), c.name, io::integrator_name(c.integrator), c.dt_s,
                      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()),
          static_cast<double>(done) / (cases.size() + 1));
    }
  };
  report_progress(progress,
                  fmt::format("{} cases, {} at a time on {} thread{} each (large indentations, "
                              "pulls, tools; the dt sweep)",
                              cases.size(), workers, threads_each, threads_each > 1 ? "s" : ""),
                  0.0);
  std::vector<std::thread> pool;
  for (unsigned w = 1; w < workers; ++w) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  omp_set_num_threads(caller_threads);
  if (failure) std::rethrow_exception(failure);
  report_progress(progress, "done", 1.0);

  fmt::print(stderr, "{:>14} {:>19} {:>7} {:>9} {:>8} {:>7} {:>8} {:>5} {:>9} {:>9} {:>6} {:>5}\n",
             "case", "integrator", "dt s", "peak mm", "vol %", "outside", "inverted", "recov",
             "E rise", "rest mm", "steps", "pass");
  int passed = 0;
  for (const StabilityResult& r : rows) {
    const bool ok = r.passed(options);
    passed += ok;
    fmt::print(stderr,
               "{:>14} {:>19} {:>7g} {:>9.2f} {:>8.3f} {:>7} {:>8} {:>5} {:>8.2f}% {:>9.4f} {:>6} "
               "{:>5}\n",
               r.c.name, io::integrator_name(r.c.integrator), r.c.dt_s, r.peak_displacement_mm,
               r.peak_volume_change_pct, r.order.outside_nodes, r.order.inverted_tets, r.recoveries,
               100.0 * r.energy_rise(), r.rest_error_mm, r.steps, ok ? "yes" : "NO");
  }
  for (const StabilityResult& r : rows)
    if (!r.passed(options)) fmt::print(stderr, "{:>14}: {}\n", r.c.name, r.failure(options));
  const std::string hold =
      support.nodes.empty()
          ? fmt::format("held by its posterior {:g} mm", ind.held_distance_mm)
          : fmt::format("held by its posterior {:g} mm and the scene's support of {:.0f} mm^2",
                        ind.held_distance_mm, support.area_mm2);
  const std::string verdict = fmt::format(
      "stability: {} of {} cases passed (organ depth {:.1f} mm, {}, rest tolerance {:g} mm)",
      passed, rows.size(), ind.organ_depth_mm, hold, options.rest_tolerance_mm);
  if (passed == static_cast<int>(rows.size()))
    log::info("{}", verdict);
  else
    log::warn("{}", verdict);

  nlohmann::ordered_json j;
  j["input"] = m.source;
  j["nodes"] = m.node_count();
  j["layers"] = m.layer_count();
  j["organ_depth_mm"] = ind.organ_depth_mm;
  j["indenter_radius_mm"] = ind.radius_mm;
  j["rest_tolerance_mm"] = options.rest_tolerance_mm;
  j["held_distance_mm"] = ind.held_distance_mm;
  j["supported_nodes"] = support.nodes.size();
  j["supported_area_mm2"] = support.area_mm2;
  j["base_dt_s"] = dt;
  j["tets"] = m.tets.size();
  j["cases_passed"] = passed;
  j["all_passed"] = passed == static_cast<int>(rows.size());
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (const StabilityResult& r : rows) {
    nlohmann::ordered_json o;
    o["case"] = r.c.name;
    o["kind"] = kind_name(r.c.kind);
    o["integrator"] = io::integrator_name(r.c.integrator);
    o["dt_s"] = r.c.dt_s;
    o["passed"] = r.passed(options);
    o["failure"] =
        r.passed(options) ? nlohmann::ordered_json() : nlohmann::ordered_json(r.failure(options));
    o["unstable_reason"] = r.unstable == sim::Instability::kNone
                               ? nlohmann::ordered_json()
                               : nlohmann::ordered_json(sim::describe(r.unstable));
    o["finite"] = r.finite;
    o["recoveries"] = r.recoveries;
    o["outside_nodes"] = r.order.outside_nodes;
    o["surfaces_cross"] = r.order.surfaces_cross;
    o["inverted_tets"] = r.order.inverted_tets;
    o["inverted_tets_in_motion"] = r.order_in_motion.inverted_tets;
    o["outside_nodes_in_motion"] = r.order_in_motion.outside_nodes;
    o["order_checks"] = r.order_checks;
    o["peak_displacement_mm"] = r.peak_displacement_mm;
    o["peak_volume_change_pct"] = r.peak_volume_change_pct;
    o["loaded_at_rest"] = r.loaded_at_rest;
    o["release_energy_j"] = r.release_energy_j;
    o["max_energy_j"] = r.max_energy_j;
    o["final_energy_j"] = r.final_energy_j;
    o["energy_decays"] = r.energy_decays(options);
    o["returned_at_rest"] = r.returned_at_rest;
    o["rest_error_mm"] = r.rest_error_mm;
    o["steps"] = r.steps;
    o["seconds"] = r.seconds;
    list.push_back(o);
  }
  j["cases"] = list;
  if (!a.output.empty()) {
    const fs::path out = a.output;
    create_folder(out);
    write_text(out / "stability.csv", csv_of(rows, options));
    write_text(out / "stability_energy.csv", energy_csv_of(rows));
    write_text(out / "summary.json", j.dump(2) + "\n");
    draw_plots(out, rows, dt, options);
    log::info(
        "wrote {}: stability.csv, stability_energy.csv, summary.json, "
        "stability_energy.png, stability_dt.png",
        out.string());
  }
  if (a.json) std::cout << j.dump(2) << "\n";
  return 0;
}

}  // namespace lamina::cli
