// `lamina soak`: a long run under random tools, the check that a simulator left running for hours
// in a training centre stays sound. Random pokes and pulls (up to three at once) on random skin
// nodes for STEPS steps, and --cuts random incisions spread over them (issue 47: through nodes,
// along a skin edge, the same blade again, grazing the skin, in turn; one that would cut a piece
// off, which nothing would hold, is skipped and counted); every SAMPLE steps the resident memory,
// the skin volume, the largest displacement and the recovery count are logged. Then every tool
// lets go and the model must return to rest. Pass: every state finite, memory flat after
// warm-up (and after each cut, which adds nodes), volume drift bounded, back at rest. A failure
// exits with code 1 after writing its report (docs/testing.md).
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <random>

#include "commands.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/interact/scalpel.h"
#include "lamina/interact/tools.h"
#include "lamina/io/scene.h"
#include "lamina/sim/simulation.h"
#include "plots.h"

namespace lamina::cli {
namespace {

// Resident set size, MB (/proc/self/statm: pages).
double resident_mb() {
  std::ifstream statm("/proc/self/statm");
  long pages = 0, resident = 0;
  statm >> pages >> resident;
  return static_cast<double>(resident) * static_cast<double>(::sysconf(_SC_PAGESIZE)) / (1 << 20);
}

// The skin nodes a tool can load: those of the skin's triangles (a cut's copy of a skin node
// may carry none: its triangles went to the other copy).
std::vector<int32_t> skin_nodes(const Model& m) {
  std::vector<int32_t> nodes;
  const ModelLayer& skin = m.layers[0];
  std::vector<uint8_t> on(static_cast<size_t>(skin.node_count), 0);
  for (Eigen::Index f = 0; f < skin.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) on[static_cast<size_t>(skin.F(f, k))] = 1;
  for (int32_t i = 0; i < skin.node_count; ++i)
    if (on[static_cast<size_t>(i)]) nodes.push_back(skin.first_node + i);
  return nodes;
}

struct ActiveTool {
  interact::ForceRoute route;
  double end_s = 0.0;
};

// A random incision's blade at the current shape x, of kind `kind` (0 through two skin nodes, 1
// along a skin triangle's edge, 3 grazing the skin; 2, the same blade again, is the caller's).
struct RandomBlade {
  std::vector<Eigen::Vector3d> path;
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();
  double depth_mm = 10.0;
};
RandomBlade random_blade(const Model& m, const Eigen::MatrixX3d& x, int kind,
                         std::mt19937_64& rng) {
  const Eigen::Vector3d centre = x.topRows(m.layers[0].node_count).colwise().mean();
  const std::vector<int32_t> nodes = skin_nodes(m);
  std::uniform_int_distribution<size_t> pick(0, nodes.size() - 1);
  const auto node = [&](std::mt19937_64& r) { return nodes[pick(r)]; };
  std::uniform_int_distribution<Eigen::Index> face(0, m.layers[0].F.rows() - 1);
  std::uniform_real_distribution<double> depth(10.0, 30.0);
  RandomBlade b;
  Eigen::Vector3d a, z;
  if (kind == 1) {  // along an edge of a skin triangle, a little past both ends
    const Eigen::Index f = face(rng);
    a = x.row(m.layers[0].F(f, 0)).transpose(), z = x.row(m.layers[0].F(f, 1)).transpose();
    const Eigen::Vector3d d = z - a;
    a -= 1.5 * d, z += 1.5 * d;
  } else {  // from a skin node to another near it, through both
    a = x.row(node(rng)).transpose();
    z = a;
    for (int tries = 0; tries < 50 && ((z - a).norm() < 5.0 || (z - a).norm() > 40.0); ++tries)
      z = x.row(node(rng)).transpose();
  }
  const Eigen::Vector3d inward = (centre - 0.5 * (a + z)).normalized();
  b.direction = inward;
  b.depth_mm = depth(rng);
  if (kind == 3) {  // grazing: a blade 1 mm deep, tilted towards the path
    b.direction = (inward + 3.0 * (z - a).normalized()).normalized();
    b.depth_mm = 1.0;
  }
  // The blade's upper end 2 mm outside the skin, along the path.
  b.path = {a - 2.0 * inward, z - 2.0 * inward};
  return b;
}

}  // namespace

int run_soak(const SoakArgs& a) {
  if (a.steps < 1000) throw invalid_input("--steps", "must be at least 1000");
  check_output_folder(a.output);
  // The default scene: the physical liver (tetrahedra; E, nu, density, critical damping;
  // implicit Euler at 1 ms; its posterior surface supported); a scene can name any other model
  // and material.
  io::Scene scene = a.scene.empty() ? io::Scene{} : io::load_scene(a.scene);
  const ProgressFn progress = stderr_progress(a.verbose);
  report_progress(progress, "soak: building the model", 0.0);
  const io::ReadyScene ready = io::make_ready_scene(scene, volume_read_options, {});
  scene = ready.scene;
  io::warn_scalpels_ignored(scene);
  std::shared_ptr<const Model> model = ready.model;  // a cut replaces it
  sim::Simulation s = io::make_scene_simulation(ready);
  // The folder now, not after an hour of stepping: a path that cannot be made fails at once.
  const std::filesystem::path out(a.output);
  create_folder(out);

  // Random tools: a new one every 0.05-0.5 s (at most three at once) on a random skin node,
  // 0.05-0.5 N pushing or pulling in a random direction, held 0.1-1 s.
  std::mt19937_64 rng(a.seed);
  std::uniform_real_distribution<double> gap(0.05, 0.5), hold(0.1, 1.0), newtons(0.05, 0.5);
  std::vector<int32_t> nodes = skin_nodes(*model);
  std::uniform_int_distribution<size_t> pick(0, nodes.size() - 1);
  std::normal_distribution<double> axis(0.0, 1.0);
  std::vector<ActiveTool> tools;
  interact::Loads loads;
  double next_tool_s = 0.0;
  int64_t tools_applied = 0;
  std::vector<int32_t> touched;  // local mode: every node a tool has loaded stays movable

  std::string csv =
      "step,time_s,resident_mb,volume_change_pct,max_displacement_mm,recoveries,"
      "failed_steps,active_tools\n";
  double rss_after_warmup = 0.0, rss_max_growth = 0.0, max_abs_volume = 0.0, max_displacement = 0.0;
  int64_t failed_steps = 0;
  bool finite = true;
  const int64_t sample = std::max<int64_t>(1, a.steps / 2000);
  const int64_t warmup = a.steps / 10;
  // The cuts, evenly spread; the memory baseline is taken again after each (it adds nodes).
  int32_t cuts_made = 0, cuts_separating = 0, cuts_done = 0;
  int64_t cut_tets = 0;
  double rss_base = 0.0;
  RandomBlade last_blade;
  std::vector<std::string> cut_errors;
  for (int64_t k = 0; k < a.steps; ++k) {
    if (cuts_done < a.cuts && k == (cuts_done + 1) * a.steps / (a.cuts + 1)) {
      const int kind = cuts_done % 4;
      ++cuts_done;
      const RandomBlade b =
          kind == 2 && !last_blade.path.empty() ? last_blade : random_blade(*model, s.x, kind, rng);
      last_blade = b;
      // The tools let go first (their nodes are renumbered); a cut that would leave a piece
      // nothing holds is not made.
      tools.clear();
      interact::clear_loads(s, loads);
      touched.clear();
      std::shared_ptr<const Model> trial_model = model;
      sim::Simulation trial = s;
      interact::ToolDriver none;
      std::vector<int32_t> origin;
      try {
        const model::CutReport r =
            interact::cut_now(trial_model, trial, none, b.path, b.direction, b.depth_mm, origin);
        if (r.pieces.size() > 1) {
          ++cuts_separating;
        } else if (r.cut_tets > 0) {  // (the same blade again divides nothing: copies stay)
          model = std::move(trial_model);
          s = std::move(trial);
          nodes = skin_nodes(*model);
          pick = std::uniform_int_distribution<size_t>(0, nodes.size() - 1);
          ++cuts_made;
          cut_tets += r.cut_tets;
          rss_base = 0.0;
        }
      } catch (const Error& e) {  // a blade that misses the organ, say: counted, not fatal
        cut_errors.push_back(e.what());
      }
    }
    const Model& m = *model;
    if (s.time_s >= next_tool_s && tools.size() < 3) {
      Eigen::Vector3d dir(axis(rng), axis(rng), axis(rng));
      dir.normalize();
      ActiveTool t;
      t.route = interact::load_at_node(m, s.x, nodes[pick(rng)], 1000.0 * newtons(rng) * dir,
                                       interact::kDefaultPatchRadiusMm, scene.routing);
      t.end_s = s.time_s + hold(rng);
      touched.insert(touched.end(), t.route.nodes.begin(), t.route.nodes.end());
      interact::keep_touched_movable(s, touched);
      tools.push_back(std::move(t));
      next_tool_s = s.time_s + gap(rng);
      ++tools_applied;
    }
    std::erase_if(tools, [&](const ActiveTool& t) { return s.time_s >= t.end_s; });
    interact::clear_loads(s, loads);
    for (const ActiveTool& t : tools) interact::add_load(s, t.route, loads);
    const sim::StepStats st = sim::step(s);
    failed_steps += st.failed ? 1 : 0;
    finite = finite && std::isfinite(st.volume_change_pct) &&
             std::isfinite(st.max_displacement_mm) && st.unstable == sim::Instability::kNone;
    max_abs_volume = std::max(max_abs_volume, std::abs(st.volume_change_pct));
    max_displacement = std::max(max_displacement, st.max_displacement_mm);
    if (k % sample == 0 || k + 1 == a.steps) {
      const double rss = resident_mb();
      if (k >= warmup) {
        if (rss_after_warmup == 0.0) rss_after_warmup = rss;
        if (rss_base == 0.0) rss_base = rss;
        rss_max_growth = std::max(rss_max_growth, rss - rss_base);
      }
      fmt::format_to(std::back_inserter(csv), "{},{:.6g},{:.2f},{:.6g},{:.6g},{},{},{}\n", k + 1,
                     s.time_s, rss, st.volume_change_pct, st.max_displacement_mm, s.recoveries,
                     failed_steps, tools.size());
      report_progress(progress,
                      fmt::format("soak: step {} of {}, {} tools so far, {:.1f} MB", k + 1, a.steps,
                                  tools_applied, rss),
                      0.9 * static_cast<double>(k + 1) / static_cast<double>(a.steps));
    }
  }
  // Every tool lets go: the model must come back.
  tools.clear();
  interact::clear_loads(s, loads);
  report_progress(progress, "soak: released, returning to rest", 0.9);
  const sim::StepStats rest = sim::run_to_convergence(s, 10);
  const Model& m = *model;
  const double rest_error = std::sqrt((s.x - m.X).rowwise().squaredNorm().maxCoeff());
  // The node moving fastest at the end, for a run that did not come to rest: which, how light.
  Eigen::Index fastest = 0;
  s.v.rowwise().norm().maxCoeff(&fastest);
  finite = finite && s.x.allFinite() && s.v.allFinite();

  // The criteria (docs/testing.md): memory after warm-up grows by at most 2 MB (a leak of even
  // 2 bytes per step would show over a million steps), no NaN, no failed step, the skin volume
  // back within 0.1% of rest and the shape within 0.05 mm.
  const double rss_growth = rss_max_growth;
#if defined(__SANITIZE_ADDRESS__)
  // AddressSanitizer holds freed memory in its quarantine (up to 256 MB), so resident memory
  // grows without a leak; LeakSanitizer checks for real leaks at exit instead.
  const bool memory_checked = false;
#else
  const bool memory_checked = true;
#endif
  const bool memory_flat = !memory_checked || rss_growth <= 2.0;
  const bool volume_ok = std::abs(rest.volume_change_pct) <= 0.1;
  const bool at_rest = rest.converged && rest_error <= 0.05;
  // A soak whose tools moved nothing tested nothing (a model held everywhere, say).
  const bool deformed = max_displacement > 0.0;
  const bool passed =
      finite && failed_steps == 0 && memory_flat && volume_ok && at_rest && deformed;

  write_text(out / "soak.csv", csv);
  nlohmann::ordered_json j;  // the same JSON library as every other summary the CLI writes
  j["passed"] = passed;
  j["steps"] = a.steps;
  j["sim_seconds"] = s.time_s;
  j["seed"] = a.seed;
  j["nodes"] = m.node_count();
  j["integrator"] = io::integrator_name(scene.solver.integrator);
  j["tools_applied"] = tools_applied;
  j["cuts"] = cuts_made;
  j["cut_tets"] = cut_tets;
  j["cuts_tried"] = cuts_done;
  j["cuts_dividing_nothing"] =
      cuts_done - cuts_made - cuts_separating - static_cast<int32_t>(cut_errors.size());
  j["cuts_skipped_separating"] = cuts_separating;
  j["cuts_refused"] = cut_errors.size();
  j["finite"] = finite;
  j["recoveries"] = s.recoveries;
  j["failed_steps"] = failed_steps;
  j["resident_mb_after_warmup"] = rss_after_warmup;
  j["resident_mb_growth"] = rss_growth;
  j["memory_checked"] = memory_checked;
  j["memory_flat"] = memory_flat;
  j["max_displacement_mm"] = max_displacement;
  j["deformed"] = deformed;
  j["max_abs_volume_change_pct"] = max_abs_volume;
  j["rest_volume_change_pct"] = rest.volume_change_pct;
  j["rest_error_mm"] = rest_error;
  j["rest_max_speed_mm_per_s"] = rest.max_speed_mm_per_s;
  j["rest_fastest_node"] = fastest;
  j["rest_fastest_node_mass_kg"] = s.mass_kg()[static_cast<size_t>(fastest)];
  j["returned_to_rest"] = at_rest;
  const std::string json = j.dump(2);
  write_text(out / "summary.json", json + "\n");
  if (!a.no_plot) {
    const std::string gnuplot = find_gnuplot();
    // Three stacked panels need a taller page than the common style's.
    draw_plot(gnuplot, out, "soak",
              std::string(kPlotStyle) + "set terminal pngcairo size 1000,1000\n",
              fmt::format("set multiplot layout 3,1\nset xlabel 'simulated time (s)'\n"
                          "set ylabel 'resident memory (MB)'\nset yrange [0:*]\n"
                          "plot {0} using 2:3 with lines lw 2 title 'resident memory'\n"
                          "set ylabel 'skin volume change (%)'\nset autoscale y\n"
                          "plot {0} using 2:4 with lines title 'volume change'\n"
                          "set ylabel 'largest displacement (mm)'\nset yrange [0:*]\n"
                          "plot {0} using 2:5 with lines title 'largest node displacement'\n"
                          "unset multiplot\n",
                          quote(out / "soak.csv")));
  }
  report_progress(progress, "soak: done", 1.0);
  if (a.json) {
    std::cout << json << "\n";
  } else {
    std::cout << fmt::format(
        "lamina soak: {} steps ({:.0f} s simulated) on {} nodes, {} random tools, {} cut(s): {}\n"
        "  finite {}, failed steps {}, recoveries {}; memory {:.1f} MB, +{:.2f} MB after "
        "warm-up; displacement up to {:.3g} mm; |volume change| up to {:.3g}%, {:.3g}% at rest; "
        "rest error {:.3g} mm\n"
        "  wrote {}: soak.csv, summary.json{}\n",
        a.steps, s.time_s, m.node_count(), tools_applied, cuts_made, passed ? "PASSED" : "FAILED",
        finite ? "yes" : "NO", failed_steps, s.recoveries, rss_after_warmup, rss_growth,
        max_displacement, max_abs_volume, rest.volume_change_pct, rest_error, a.output,
        a.no_plot ? "" : ", soak.png");
  }
  if (!passed)
    throw Error(ErrorKind::kInternal,
                fmt::format("soak: FAILED (finite {}, failed steps {}, memory +{:.2f} MB, "
                            "displacement up to {:.3g} mm, rest volume {:.3g}%, rest error {:.3g} "
                            "mm): see {}/summary.json",
                            finite, failed_steps, rss_growth, max_displacement,
                            rest.volume_change_pct, rest_error, a.output));
  return 0;
}

}  // namespace lamina::cli
