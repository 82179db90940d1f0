// `lamina figures`: the reference paper's results (figures 4, 5 and 6) and the volume claim,
// reproduced on any organ. Data go to CSV files, plots are drawn by gnuplot from scripts written
// beside them (so a researcher can restyle them), snapshots by the project's own renderer.
#include <fmt/format.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <iostream>

#include "commands.h"
#include "lamina/core/atomic_file.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/interact/tools.h"
#include "lamina/io/scene.h"
#include "lamina/render/camera.h"
#include "lamina/render/offscreen.h"
#include "lamina/render/renderer.h"
#include "lamina/sim/simulation.h"
#include "paper_run.h"
#include "plots.h"

namespace lamina::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

}  // namespace

int run_figures(const FiguresArgs& a) {
  const auto t_start = Clock::now();
  check_output_folder(a.output);
  const std::string gnuplot = find_gnuplot();
  render::HeadlessContext context;  // no EGL: say so before any long work
  render::Renderer renderer;
  const ProgressFn progress = stderr_progress(a.verbose);
  const fs::path out = fs::absolute(a.output);

  // Models: the paper's two layers, and a skin-only one for the volume comparison.
  io::Scene scene = io::scene_for(a.input);
  scene.build.structure = model::Structure::kLinks;  // the paper's network
  scene.build.layers = 2;
  scene.build.locality = 6;  // figure 5 sweeps N = 1..6
  report_progress(progress, "figures: building the 2-layer model", 0.0);
  const io::SceneModel two = io::make_scene_model(scene, volume_read_options, {});
  scene.build.layers = 1;
  report_progress(progress, "figures: building the skin-only model", 0.05);
  const io::SceneModel one = io::make_scene_model(scene, volume_read_options, {});
  create_folder(out);  // only once the input has been read and modelled
  const Setup base = paper_setup(two.model);
  const int32_t contact = base.tools.empty() ? 0 : base.tools[0].vertex;
  const double t_end = a.quick ? 6.0 : 10.0;

  // Figure 4: one surface node's displacement for (gamma, K) = (3,3), (5,3), (3,6).
  report_progress(progress, "figures: fig. 4 trajectories", 0.1);
  const std::pair<double, double> params[3] = {{3, 3}, {5, 3}, {3, 6}};
  std::vector<std::vector<double>> disp(3);
  std::vector<double> times;
  for (int k = 0; k < 3; ++k) {
    Setup s = base;
    s.material.damping_kg_per_s = params[k].first;
    s.material.stiffness_n_per_m = params[k].second;
    simulate(s, t_end, false,
             [&](const sim::Simulation& sim, const interact::ToolDriver&, const sim::StepStats&) {
               if (k == 0) times.push_back(sim.time_s);
               disp[k].push_back((sim.x.row(contact) - two.model.X.row(contact)).norm());
             });
  }
  std::string csv = "time_s,gamma3_k3_mm,gamma5_k3_mm,gamma3_k6_mm\n";
  for (size_t i = 0; i < times.size(); ++i)
    csv +=
        fmt::format("{:.4f},{:.6g},{:.6g},{:.6g}\n", times[i], disp[0][i], disp[1][i], disp[2][i]);
  write_text(out / "fig4_trajectories.csv", csv);
  const double force_n = base.tools.empty() ? 0.0 : base.tools[0].force_mn.norm() / 1000.0;
  draw_plot(gnuplot, out, "fig4_trajectories", kPlotStyle,
            fmt::format("set title \"Displacement of skin node {} under a {:.2g} N poke "
                        "(0-1 s), then release\"\n",
                        contact, force_n) +
                "set xlabel 'time (s)'\nset ylabel 'displacement (mm)'\n"
                "set object 1 rect from 0,graph 0 to 1,graph 1 fc rgb '#f3e9d2' fs solid "
                "noborder behind\n" +
                fmt::format("plot {0} using 1:2 with lines lc rgb '#1f77b4' title "
                            "'{{/Symbol g}} = 3, K = 3', \\\n"
                            "     {0} using 1:3 with lines lc rgb '#d62728' title "
                            "'{{/Symbol g}} = 5, K = 3', \\\n"
                            "     {0} using 1:4 with lines lc rgb '#2ca02c' title "
                            "'{{/Symbol g}} = 3, K = 6'\n",
                            quote(out / "fig4_trajectories.csv")));

  // Figure 5: wall time from the poke to rest against locality, for two thresholds.
  const int max_n = a.quick ? 3 : 6, repeats = a.quick ? 1 : 3;
  csv = "locality,threshold_mm,median_ms,steps,converged\n";
  std::string table;
  for (int n = 1; n <= max_n; ++n) {
    report_progress(progress, fmt::format("figures: fig. 5 timing, N = {}", n),
                    0.3 + 0.4 * (n - 1) / max_n);
    for (double threshold : {1e-3, 1e-4}) {
      Setup s = base;
      s.routing.locality = n;
      s.solver.rest_speed_mm_per_s = threshold / s.solver.dt_s;  // the paper's move per step
      s.solver.max_steps = 100000;
      std::vector<double> ms;
      RunStats r;
      for (int rep = 0; rep < repeats; ++rep) {
        r = simulate(s, 1000.0, true);
        ms.push_back(1000.0 * r.wall_s);
      }
      std::nth_element(ms.begin(), ms.begin() + ms.size() / 2, ms.end());
      csv += fmt::format("{},{:g},{:.3f},{},{}\n", n, threshold, ms[ms.size() / 2], r.steps,
                         r.converged ? 1 : 0);
    }
  }
  write_text(out / "fig5_timing.csv", csv);
  draw_plot(gnuplot, out, "fig5_timing", kPlotStyle,
            "set title 'Computation time from a poke to rest (median wall time, this "
            "machine)'\n"
            "set xlabel 'locality N (rings receiving force)'\nset ylabel 'time to "
            "convergence (ms)'\nset xtics 1\nset key top left box opaque\n"
            "set style data linespoints\n" +
                fmt::format("plot {0} every ::1 using ($2 == 0.001 ? $1 : 1/0):3 pt 7 lc rgb "
                            "'#1f77b4' title 'threshold 10^{{-3}} mm', \\\n"
                            "     {0} every ::1 using ($2 == 0.0001 ? $1 : 1/0):3 pt 5 lc rgb "
                            "'#d62728' title 'threshold 10^{{-4}} mm'\n",
                            quote(out / "fig5_timing.csv")));

  // Volume: skin volume change under the same poke, 2 layers against the skin alone.
  report_progress(progress, "figures: volume change", 0.72);
  std::vector<double> vol_two, vol_one, vol_t;
  simulate(base, t_end, false,
           [&](const sim::Simulation& sim, const interact::ToolDriver&, const sim::StepStats& st) {
             vol_t.push_back(sim.time_s);
             vol_two.push_back(st.volume_change_pct);
           });
  Setup skin_only = paper_setup(one.model);
  // Its own default poke: the same rule (the most anterior skin node, 0.4 N, 0-1 s).
  simulate(skin_only, t_end, false,
           [&](const sim::Simulation&, const interact::ToolDriver&, const sim::StepStats& st) {
             vol_one.push_back(st.volume_change_pct);
           });
  csv = "time_s,two_layers_pct,skin_only_pct\n";
  double worst_two = 0.0, worst_one = 0.0;
  for (size_t i = 0; i < vol_t.size() && i < vol_one.size(); ++i) {
    csv += fmt::format("{:.4f},{:.6g},{:.6g}\n", vol_t[i], vol_two[i], vol_one[i]);
    worst_two = std::max(worst_two, std::abs(vol_two[i]));
    worst_one = std::max(worst_one, std::abs(vol_one[i]));
  }
  write_text(out / "volume_change.csv", csv);
  draw_plot(gnuplot, out, "volume_change", kPlotStyle,
            "set title 'Skin volume change under the same poke (0-1 s)'\n"
            "set xlabel 'time (s)'\nset ylabel 'skin volume change (%)'\n"
            "set key right center box opaque\n"
            "set object 1 rect from 0,graph 0 to 1,graph 1 fc rgb '#f3e9d2' fs solid "
            "noborder behind\n" +
                fmt::format("plot {0} using 1:2 with lines lc rgb '#1f77b4' title "
                            "'multi-layer (2 layers)', \\\n"
                            "     {0} using 1:3 with lines lc rgb '#d62728' title "
                            "'skin only (1 layer)'\n",
                            quote(out / "volume_change.csv")));

  // Figure 6: a large deformation by two tools at once and its recovery, rendered.
  report_progress(progress, "figures: fig. 6 snapshots", 0.8);
  Setup big = base;
  big.tools[0].force_mn *= 3.0;  // 1.2 N push on the anterior node
  interact::Tool pull;
  int32_t lateral = 0;
  for (int32_t i = 0; i < two.model.layers[0].node_count; ++i)
    if (two.model.X(i, 0) > two.model.X(lateral, 0)) lateral = i;
  pull.vertex = lateral;
  pull.force_mn = Eigen::Vector3d(1000.0, 0.0, 0.0);  // 1 N pull to the patient's left
  pull.start_s = 0.0;
  pull.end_s = 1.0;
  big.tools.push_back(pull);
  const double shots[6] = {0.0, 0.5, 1.0, 1.5, 3.0, t_end};
  const render::Camera camera = render::fit_camera(two.model, -25.0, 25.0);
  size_t next = 0;
  std::string montage;
  auto shoot = [&](const sim::Simulation& sim, const interact::ToolDriver& driver) {
    render::Frame f;
    f.model = &two.model;
    f.x = &sim.x;
    f.style.background = {1.0f, 1.0f, 1.0f, 1.0f};
    f.style.coloring = render::Coloring::kDisplacement;
    f.style.displacement_range_mm = 30.0f;
    int acting = 0;
    for (size_t t = 0; t < driver.tools.size(); ++t) {
      if (t >= driver.active.size() || !driver.active[t]) continue;
      ++acting;
      const int32_t node = driver.routes[t].contact_node;
      render::add_force_arrow(f, node, driver.tools[t].force_mn, 40.0, {0.1f, 0.1f, 0.1f, 1.0f});
      render::add_contact_marker(f, node, {0.1f, 0.8f, 0.2f, 1.0f});
    }
    const std::string name = fmt::format("fig6_t{:05.2f}.png", sim.time_s);
    render::write_png(render::render_image(renderer, f, camera, 640, 480), (out / name).string());
    const double max_d = std::sqrt((sim.x - two.model.X).rowwise().squaredNorm().maxCoeff());
    montage += fmt::format(
        "set title \"t = {:.1f} s: {}, largest displacement {:.1f} mm\"\nplot {} binary "
        "filetype=png with rgbimage\n",
        sim.time_s, acting ? fmt::format("{} tools acting", acting) : "released", max_d,
        quote(out / name));
  };
  simulate(big, t_end, false,
           [&](const sim::Simulation& sim, const interact::ToolDriver& d, const sim::StepStats&) {
             while (next < 6 && sim.time_s >= shots[next] - 1e-9) shoot(sim, d), ++next;
           });
  draw_plot(gnuplot, out, "fig6_snapshots",
            "set terminal pngcairo size 1500,880 enhanced font 'DejaVu Sans,12'\n",
            std::string("set multiplot layout 2,3 title \"Large deformation by two tools "
                        "(1.2 N push, 1 N pull, 0-1 s) and recovery\\ncolour: displacement, "
                        "organ red (0) to orange (15 mm) to yellow (30 mm); green: contacts\" "
                        "font 'DejaVu Sans,14'\n"
                        "unset border\nunset tics\nunset key\nset size ratio -1\n"
                        "set lmargin 0\nset rmargin 0\nset tmargin 2\nset bmargin 0\n") +
                montage + "unset multiplot\n");

  report_progress(progress, "figures: done", 1.0);
  std::cout << fmt::format(
      "lamina figures: {} ({} nodes, 2 layers) in {:.1f} s\n"
      "  fig4_trajectories.png  node {} under {:.2g} N for (gamma, K) = (3,3), (5,3), (3,6)\n"
      "  fig5_timing.png        time to rest for N = 1..{} at 1e-3 and 1e-4 mm (data: "
      "fig5_timing.csv)\n"
      "  fig6_snapshots.png     large deformation by two tools and recovery\n"
      "  volume_change.png      largest |skin volume change|: {:.3g}% with 2 layers, {:.3g}% "
      "skin only\n"
      "  wrote {}\n",
      two.source, two.model.node_count(),
      std::chrono::duration<double>(Clock::now() - t_start).count(), contact, force_n, max_n,
      worst_two, worst_one, a.output);
  return 0;
}

}  // namespace lamina::cli
