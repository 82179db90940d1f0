#include "commands.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <regex>
#include <thread>

#include "lamina/core/atomic_file.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/interact/tools.h"
#include "lamina/io/label_volume_io.h"
#include "lamina/io/mesh_file.h"
#include "lamina/io/model_file.h"
#include "lamina/io/scene.h"
#include "lamina/io/summary_json.h"
#include "lamina/model/compute_rings.h"
#include "lamina/model/summarize_model.h"
#include "lamina/sim/simulation.h"

namespace lamina::cli {
bool has_suffix(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

namespace {}  // namespace

void check_output(const std::string& path, const std::vector<std::string>& extensions,
                  const char* what) {
  bool ok = false;
  for (const auto& e : extensions) ok |= has_suffix(path, e);
  if (!ok) {
    std::string list;
    for (const auto& e : extensions) list += (list.empty() ? "" : ", ") + e;
    throw invalid_input(path,
                        std::string("unsupported ") + what + " file extension (use " + list + ")");
  }
  const std::filesystem::path p(path);
  if (p.has_parent_path() && !std::filesystem::is_directory(p.parent_path()))
    throw Error(ErrorKind::kOutput, path + ": cannot write: directory '" +
                                        p.parent_path().string() + "' does not exist");
}

ProgressFn stderr_progress(bool verbose) {
  // On a terminal: one line, overwritten in place (main() clears it before an error). Elsewhere
  // (logs, scripts) one line per stage, with -v only: an error must stay the only line.
  const bool tty = ::isatty(2);
  if (!tty && !verbose) return {};
  return [tty](std::string_view stage, double fraction) {
    if (tty)
      std::fprintf(stderr, "\r\033[K[%3d%%] %.*s%s", static_cast<int>(fraction * 100 + 0.5),
                   static_cast<int>(stage.size()), stage.data(), fraction >= 1.0 ? "\n" : "");
    else
      std::fprintf(stderr, "[%3d%%] %.*s\n", static_cast<int>(fraction * 100 + 0.5),
                   static_cast<int>(stage.size()), stage.data());
  };
}

LabelVolume read_input(const std::string& input) {
  return input == io::kScenePhantom ? geometry::make_phantom() : io::read_label_volume(input);
}

namespace {

Model load_with_rings(const std::string& path) {
  Model m = io::load_model(path);
  m.rings = model::compute_rings(m, std::max(1, m.rings.locality));
  return m;
}

}  // namespace

int run_phantom(const PhantomArgs& a) {
  check_output(a.output, {".nii", ".nii.gz", ".nrrd", ".mha", ".mhd"}, "image");
  const LabelVolume v = geometry::make_phantom(a.options);
  io::write_label_volume(v, a.output);
  int64_t inside = 0;
  for (int32_t l : v.labels) inside += l != 0;
  log::info("wrote {}: {} x {} x {} voxels at {} x {} x {} mm, organ {:.1f} mL", a.output,
            v.frame.size[0], v.frame.size[1], v.frame.size[2], v.frame.spacing_mm[0],
            v.frame.spacing_mm[1], v.frame.spacing_mm[2],
            static_cast<double>(inside) * v.frame.voxel_volume_mm3() / 1000.0);
  return 0;
}

int run_build(const BuildArgs& a) {
  check_output(a.output, {".vtu"}, "model");
  model::check_build_options(a.options);
  const LabelVolume volume = read_input(a.input);
  const model::BuildResult built =
      model::build_model(volume, a.options, a.quiet ? ProgressFn{} : stderr_progress(a.verbose));
  // The table lists the warnings itself; with --json they go to stderr, stdout stays JSON.
  if (a.json)
    for (const auto& w : built.report.warnings) log::warn("{}: {}", volume.source, w);
  io::save_model(built.model, a.output);
  const model::ModelSummary summary = model::summarize_model(built.model, &built.report);
  if (a.json)
    std::cout << io::summary_json(summary, &built.report, volume.source) << "\n";
  else
    std::cout << io::summary_table(summary, &built.report, volume.source) << "  saved to "
              << a.output << "\n";
  return 0;
}

int run_info(const InfoArgs& a) {
  const Model m = load_with_rings(a.model);
  const model::ModelSummary summary = model::summarize_model(m);
  std::cout << (a.json ? io::summary_json(summary, nullptr, a.model) + "\n"
                       : io::summary_table(summary, nullptr, a.model));
  return 0;
}

int run_export(const ExportArgs& a) {
  check_output(a.output, {".obj", ".ply", ".vtp", ".stl", ".OBJ", ".PLY", ".VTP", ".STL"}, "mesh");
  const Model m = io::load_model(a.model);
  if (a.layer < 0 || a.layer >= m.layer_count())
    throw invalid_input("--layer", "model " + a.model + " has layers 0.." +
                                       std::to_string(m.layer_count() - 1) + ", got " +
                                       std::to_string(a.layer));
  io::write_mesh(model::layer_mesh(m, a.layer), a.output);
  log::info("wrote layer {} of {} to {}", a.layer, a.model, a.output);
  return 0;
}

// ---------------------------------------------------------------------------------------------
// lamina run

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

}  // namespace

void check_output_folder(const std::string& dir) {
  std::error_code ec;
  const fs::path p = fs::absolute(dir, ec);
  if (fs::exists(p, ec) && !fs::is_directory(p, ec))
    throw Error(ErrorKind::kOutput, dir + ": cannot write: it exists and is not a folder");
  fs::path probe = p;
  while (!fs::exists(probe, ec) && probe.has_parent_path() && probe != probe.parent_path())
    probe = probe.parent_path();
  if (!fs::is_directory(probe, ec))
    throw Error(ErrorKind::kOutput,
                dir + ": cannot write: '" + probe.string() + "' is not a folder");
  if (::access(probe.c_str(), W_OK | X_OK) != 0)
    throw Error(ErrorKind::kOutput,
                dir + ": cannot write: folder '" + probe.string() + "' is not writable");
}

void create_folder(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    throw Error(ErrorKind::kOutput, dir.string() + ": cannot create the folder: " + ec.message());
}

namespace {

// Frames of an earlier run in the same folder would be mistaken for this run's (a longer earlier
// run leaves higher-numbered files); only names this command writes are removed.
void remove_stale_frames(const fs::path& frames) {
  static const std::regex kFrameName(R"((skin|layer[0-9]+)_[0-9]{6}\.(vtp|obj))");
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(frames, ec))
    if (e.is_regular_file(ec) && std::regex_match(e.path().filename().string(), kFrameName))
      fs::remove(e.path(), ec);
}

}  // namespace

SceneModel make_scene_model(const io::Scene& scene, const ProgressFn& progress) {
  SceneModel out;
  // Rings must reach as far as the routing spreads force (RoutingOptions::locality).
  const int32_t locality = std::max(scene.build.locality, scene.routing.locality);
  if (!scene.model_path.empty()) {
    out.source = scene.model_path;
    out.model = io::load_model(scene.model_path);
    if (scene.density_given) {
      // Lumped masses are proportional to the density they were computed with.
      const double scale = scene.build.density_kg_per_mm3 / out.model.density_kg_per_mm3;
      for (double& m : out.model.mass_kg) m *= scale;
      out.model.density_kg_per_mm3 = scene.build.density_kg_per_mm3;
    }
    out.model.rings = model::compute_rings(out.model, std::max(out.model.rings.locality, locality));
    return out;
  }
  const LabelVolume volume = read_input(scene.input);
  out.source = volume.source;
  model::BuildOptions options = scene.build;
  options.locality = locality;
  out.model = model::build_model(volume, options, progress).model;
  return out;
}

io::Scene scene_for(const std::string& what) {
  if (has_suffix(what, ".json")) return io::load_scene(what);
  io::Scene scene;
  scene.source = what;
  if (has_suffix(what, ".vtu")) {
    scene.input.clear();
    scene.model_path = what;
  } else {
    scene.input = what;
  }
  return scene;
}

namespace {

// One VTK time series: a layer's mesh written at every frame, listed in NAME.pvd.
struct Series {
  std::string name;  // "skin", "layer1", ...
  int32_t layer = 0;
  SurfaceMesh mesh;  // connectivity fixed, positions updated per frame
  std::vector<std::pair<double, std::string>> files;  // time (s), path relative to OUTDIR
};

void write_frame(Series& series, const sim::Simulation& s, const fs::path& out, int32_t index,
                 bool obj) {
  const ModelLayer& layer = s.model->layers[static_cast<size_t>(series.layer)];
  series.mesh.V = s.x.middleRows(layer.first_node, layer.node_count);
  const std::string stem = fmt::format("frames/{}_{:06d}", series.name, index);
  io::write_mesh(series.mesh, (out / (stem + ".vtp")).string());
  if (obj) io::write_mesh(series.mesh, (out / (stem + ".obj")).string());
  series.files.emplace_back(s.time_s, stem + ".vtp");
}

// ParaView's collection format: one DataSet per frame with its time.
void write_pvd(const Series& series, const fs::path& out) {
  write_file_atomically((out / (series.name + ".pvd")).string(), [&](std::ostream& f) {
    f << "<?xml version=\"1.0\"?>\n"
         "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
         "  <Collection>\n";
    for (const auto& [time, file] : series.files)
      f << fmt::format("    <DataSet timestep=\"{:.10g}\" group=\"\" part=\"0\" file=\"{}\"/>\n",
                       time, file);
    f << "  </Collection>\n</VTKFile>\n";
  });
}

constexpr const char* kMetricsHeader =
    "time_s,max_displacement_mm,skin_volume_ml,volume_change_pct,kinetic_energy_j,step_us,"
    "converged,active_tools,reaction_x_mn,reaction_y_mn,reaction_z_mn\n";

void append_metrics(std::string& csv, double time_s, const sim::StepStats& st, double step_us,
                    int active_tools, const Eigen::Vector3d& reaction) {
  fmt::format_to(std::back_inserter(csv),
                 "{:.10g},{:.9g},{:.9g},{:.9g},{:.9g},{:.2f},{},{},{:.6g},{:.6g},{:.6g}\n", time_s,
                 st.max_displacement_mm, st.skin_volume_mm3 / 1000.0, st.volume_change_pct,
                 st.kinetic_energy_j, step_us, st.converged ? 1 : 0, active_tools, reaction.x(),
                 reaction.y(), reaction.z());
}

double max_rest_distance(const sim::Simulation& s) {
  return std::sqrt((s.x - s.model->X).rowwise().squaredNorm().maxCoeff());
}

}  // namespace

int run_run(const RunArgs& a) {
  const auto t_start = Clock::now();
  if (a.realtime && !(a.rate_hz > 0.0 && a.rate_hz <= 1e6))
    throw invalid_input("--rate", "must be in (0, 1e6] steps per second");
  io::Scene scene = a.scene.empty() ? io::Scene{} : io::load_scene(a.scene);
  check_output_folder(a.output);
  const bool tty = ::isatty(2);
  const ProgressFn progress = a.quiet ? ProgressFn{} : stderr_progress(a.verbose);

  // 1. The model, and the scene checked against it, before anything is written.
  SceneModel built = make_scene_model(scene, progress);
  const double model_seconds = seconds_since(t_start);
  io::resolve_scene_defaults(scene, built.model);
  io::check_scene_against_model(scene, built.model);
  const std::vector<int32_t> fixed = io::fixed_scene_nodes(scene, built.model);
  const io::MaterialReport material = io::resolve_material(scene, built.model, fixed);
  const Model& m = built.model;
  sim::Simulation s = sim::make_simulation(m, scene.material, scene.solver);
  sim::fix_nodes(s, fixed);
  if (fixed.empty() && scene.material.anchor_stiffness_n_per_m == 0.0 &&
      scene.solver.mode == sim::Mode::kGlobal)
    log::warn(
        "{}: no fixed nodes and no anchor springs: a pushed model drifts as a rigid body "
        "and may not come back to rest",
        scene.source);
  interact::ToolDriver driver;
  driver.tools = scene.tools;
  driver.routing = scene.routing;

  // 2. Outputs.
  const fs::path out(a.output);
  create_folder(out / "frames");
  remove_stale_frames(out / "frames");
  std::vector<Series> series;
  for (int32_t k = 0; k < (scene.output.all_layers ? m.layer_count() : 1); ++k) {
    Series& se = series.emplace_back();
    se.name = k == 0 ? "skin" : "layer" + std::to_string(k);
    se.layer = k;
    se.mesh = model::layer_mesh(m, k);
  }
  int32_t frame = 0;
  auto write_frames = [&] {
    for (Series& se : series) write_frame(se, s, out, frame, scene.output.obj);
    ++frame;
  };
  write_frames();

  // 3. Step until every tool has let go and the model is at rest. A tool that never ends is
  // followed until the model rests under its load. One quiet step is not enough: velocities
  // pass through zero when a tool is released and at the turning points of an oscillation, so
  // the test must hold for a settling window (0.1 s, at least 3 steps).
  const double tools_end = interact::last_tool_end(driver);
  double last_start = 0.0;
  for (const interact::Tool& t : scene.tools) last_start = std::max(last_start, t.start_s);
  const double settle_from = std::isfinite(tools_end) ? tools_end : last_start;
  const int64_t settle_steps =
      std::max<int64_t>(3, static_cast<int64_t>(std::ceil(0.1 / scene.solver.dt_s - 1e-9)));
  const double interval = scene.output.frame_interval_s;
  double next_frame_s = interval;

  std::string csv = kMetricsHeader;
  std::vector<double> step_us;
  step_us.reserve(static_cast<size_t>(std::min<int64_t>(scene.solver.max_steps, 1 << 20)));
  double max_displacement = 0.0, max_abs_volume = 0.0, first_settle_move = 0.0;
  int64_t streak = 0;
  bool converged = false;
  sim::StepStats st;
  auto last_report = Clock::now();
  const double report_every_s = tty ? 0.1 : 2.0;
  const auto period = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(a.realtime ? 1.0 / a.rate_hz : 0.0));
  auto tick = Clock::now();
  const auto loop_start = Clock::now();
  std::vector<double> lateness_us;
  if (a.realtime) lateness_us.reserve(step_us.capacity());
  double max_reaction_mn = 0.0;
  for (int64_t k = 0; k < scene.solver.max_steps; ++k) {
    const bool settling = s.time_s >= settle_from;
    const auto t0 = Clock::now();
    interact::apply_tools(s, driver);
    st = sim::step(s);
    const double us = std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
    step_us.push_back(us);
    const Eigen::Vector3d reaction = interact::reaction_force(s, driver.loads);
    max_reaction_mn = std::max(max_reaction_mn, reaction.norm());
    if (a.realtime) {
      // A haptic loop: the next step starts at its tick, not as soon as this one ends. Lateness
      // is measured against the tick; a loop that falls far behind restarts its schedule.
      tick += period;
      const auto now = Clock::now();
      if (now - tick > 50 * period) tick = now;
      std::this_thread::sleep_until(tick);
      lateness_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - tick).count());
    }
    const int active = static_cast<int>(std::count(driver.active.begin(), driver.active.end(), 1));
    max_displacement = std::max(max_displacement, st.max_displacement_mm);
    max_abs_volume = std::max(max_abs_volume, std::abs(st.volume_change_pct));
    streak = settling && st.converged ? streak + 1 : 0;
    converged = streak >= settle_steps;

    const bool frame_due = interval > 0.0 && s.time_s >= next_frame_s - 1e-9 * interval;
    if (frame_due) {
      write_frames();
      while (next_frame_s <= s.time_s + 1e-9 * interval) next_frame_s += interval;
    }
    if (scene.output.metrics_every_step || frame_due || converged ||
        k + 1 == scene.solver.max_steps)
      append_metrics(csv, s.time_s, st, us, active, reaction);
    if (converged) break;

    if (progress && seconds_since(last_report) >= report_every_s) {
      last_report = Clock::now();
      // Before release: time towards the last release. After: orders of magnitude of the
      // largest move still to lose before the threshold.
      double fraction = 0.0;
      if (!settling) {
        fraction =
            std::isfinite(settle_from) && settle_from > 0.0 ? 0.5 * s.time_s / settle_from : 0.0;
      } else {
        if (first_settle_move == 0.0) first_settle_move = std::max(st.max_move_mm, 1e-300);
        const double span = std::log(first_settle_move / scene.solver.threshold_mm);
        const double done = std::log(first_settle_move / std::max(st.max_move_mm, 1e-300));
        fraction = 0.5 + 0.5 * (span > 0.0 ? std::clamp(done / span, 0.0, 0.99) : 0.99);
      }
      report_progress(progress,
                      fmt::format("simulating: t = {:.2f} s, step {}, largest move {:.2g} mm",
                                  s.time_s, s.steps, st.max_move_mm),
                      std::min(fraction, 0.99));
    }
  }
  if (series.front().files.back().first != s.time_s) write_frames();  // the final state
  report_progress(progress, fmt::format("simulated {:.2f} s in {} steps", s.time_s, s.steps), 1.0);
  if (!converged)
    log::warn("{}: not at rest after solver.max_steps = {} steps ({:.2f} s simulated)",
              scene.source, scene.solver.max_steps, s.time_s);

  // 4. Results.
  write_file_atomically((out / "metrics.csv").string(), [&](std::ostream& f) { f << csv; });
  for (const Series& se : series) write_pvd(se, out);
  io::RunSummary sum;
  sum.scene = scene.source;
  sum.model = built.source;
  sum.material = material;
  sum.converged = converged;
  sum.steps = s.steps;
  sum.sim_seconds = s.time_s;
  sum.model_seconds = model_seconds;
  sum.max_displacement_mm = max_displacement;
  sum.max_abs_volume_change_pct = max_abs_volume;
  sum.final_rest_error_mm = max_rest_distance(s);
  sum.final_volume_change_pct = st.volume_change_pct;
  sum.recoveries = s.recoveries;
  sum.integrator = scene.solver.integrator;
  sum.mode = scene.solver.mode;
  sum.dt_s = scene.solver.dt_s;
  sum.nodes = m.node_count();
  sum.springs = static_cast<int64_t>(m.springs.size());
  sum.layers = m.layer_count();
  sum.fixed_nodes = static_cast<int32_t>(fixed.size());
  sum.tools = static_cast<int32_t>(scene.tools.size());
  if (!step_us.empty()) {
    double total = 0.0;
    for (double u : step_us) total += u;
    sum.mean_step_us = total / static_cast<double>(step_us.size());
    sum.steps_per_second = total > 0.0 ? 1e6 * static_cast<double>(step_us.size()) / total : 0.0;
    const auto mid = step_us.begin() + static_cast<std::ptrdiff_t>(step_us.size() / 2);
    std::nth_element(step_us.begin(), mid, step_us.end());
    sum.median_step_us = *mid;
  }
  sum.frames = frame;
  sum.max_reaction_n = max_reaction_mn / 1000.0;
  if (a.realtime) {
    sum.realtime = true;
    sum.rate_hz = a.rate_hz;
    sum.achieved_rate_hz = static_cast<double>(s.steps) / std::max(seconds_since(loop_start), 1e-9);
    if (!lateness_us.empty()) {
      std::sort(lateness_us.begin(), lateness_us.end());
      sum.worst_jitter_us = lateness_us.back();
      sum.p99_jitter_us = lateness_us[static_cast<size_t>(0.99 * (lateness_us.size() - 1))];
    }
  }
  sum.wall_seconds = seconds_since(t_start);
  const std::string json = io::run_summary_json(sum);
  write_file_atomically((out / "summary.json").string(),
                        [&](std::ostream& f) { f << json << "\n"; });

  if (a.json) {
    std::cout << json << "\n";
  } else {
    std::cout << fmt::format(
        "lamina run: {} on {} ({} nodes, {} layers)\n"
        "  {} after {} steps ({:.2f} s simulated) in {:.2f} s; {:.0f} steps/s\n"
        "  max displacement {:.3g} mm, max |volume change| {:.3g}%, final rest error {:.3g} mm\n"
        "  wrote {}: metrics.csv, summary.json, {}.pvd ({} frames)\n",
        scene.source, built.source, sum.nodes, sum.layers,
        converged ? "converged" : "NOT converged", sum.steps, sum.sim_seconds, sum.wall_seconds,
        sum.steps_per_second, sum.max_displacement_mm, sum.max_abs_volume_change_pct,
        sum.final_rest_error_mm, a.output, series.size() > 1 ? "skin.pvd, layer*" : "skin", frame);
    if (sum.realtime)
      std::cout << fmt::format(
          "  realtime: {:.0f} steps/s achieved of {:.0f}; step start late by {:.0f} us at worst, "
          "{:.0f} us at the 99th percentile\n",
          sum.achieved_rate_hz, sum.rate_hz, sum.worst_jitter_us, sum.p99_jitter_us);
  }
  return 0;
}

}  // namespace lamina::cli
