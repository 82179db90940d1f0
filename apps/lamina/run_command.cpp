// `lamina run`: a scene's tools push the organ, it responds; frames, metrics and a summary are
// written, and with --checkpoint-every the whole state, so that a stopped run resumes bit for bit.
#include <fmt/format.h>
#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <optional>
#include <regex>
#include <thread>

#include "commands.h"
#include "lamina/core/atomic_file.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/interact/run_tools.h"
#include "lamina/interact/tools.h"
#include "lamina/io/checkpoint.h"
#include "lamina/io/mesh_file.h"
#include "lamina/io/scene.h"
#include "lamina/io/summary_json.h"
#include "lamina/model/summarize_model.h"
#include "lamina/sim/simulation.h"

namespace lamina::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Frames of an earlier run in the same folder would be mistaken for this run's (a longer earlier
// run leaves higher-numbered files); only names this command writes are removed, and a resumed
// run keeps the `keep` frames written before its checkpoint.
void remove_stale_frames(const fs::path& frames, int32_t keep) {
  static const std::regex kFrameName(R"((skin|layer[0-9]+)_([0-9]{6})\.(vtp|obj))");
  std::error_code ec;
  std::smatch match;
  for (const auto& e : fs::directory_iterator(frames, ec)) {
    const std::string name = e.path().filename().string();
    if (e.is_regular_file(ec) && std::regex_match(name, match, kFrameName) &&
        std::stoi(match[2].str()) >= keep)
      fs::remove(e.path(), ec);
  }
}

// One VTK time series: a layer's mesh written at every frame, listed in NAME.pvd.
struct Series {
  std::string name;  // "skin", "layer1", ...
  int32_t layer = 0;
  SurfaceMesh mesh;  // connectivity fixed, positions updated per frame
  std::vector<std::pair<double, std::string>> files;  // time (s), path relative to OUTDIR
};

void write_frame(Series& series, const sim::Simulation& s, const fs::path& out, int32_t index,
                 bool obj) {
  const ModelLayer& layer = s.model().layers[static_cast<size_t>(series.layer)];
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
  return std::sqrt((s.x - s.model().X).rowwise().squaredNorm().maxCoeff());
}

// Puts a checkpoint's state back, after checking that every index in it fits this model and
// scene (the file's checksum already vouches for its bytes, not for what they refer to).
void restore_run(const io::RunCheckpoint& k, const std::string& path, sim::Simulation& s,
                 interact::ToolDriver& driver, std::vector<Series>& series) {
  const Model& m = s.model();
  const auto bad = [&](const std::string& problem) {
    return invalid_input(path, problem + ": resume with the scene and model it was written for");
  };
  const size_t tools = driver.tools.size();
  if (k.tool_active.size() != tools || k.routes.size() != tools)
    throw bad("holds the state of " + std::to_string(k.routes.size()) + " tools, the scene has " +
              std::to_string(tools));
  const auto node_ok = [&](int32_t i) { return i >= 0 && i < m.node_count(); };
  const auto all_ok = [&](const std::vector<int32_t>& v) {
    return std::all_of(v.begin(), v.end(), node_ok);
  };
  for (const interact::ForceRoute& r : k.routes) {
    bool ok =
        all_ok(r.nodes) && r.forces.allFinite() && (r.nodes.empty() || node_ok(r.contact_node));
    for (const interact::Crossing& c : r.crossings)
      ok = ok && node_ok(c.node) && c.layer >= 0 && c.layer < m.layer_count();
    if (!ok) throw bad("a tool's force route names a node outside the model");
  }
  if (!all_ok(k.touched) || !all_ok(k.loads.nodes)) throw bad("names a node outside the model");
  if (k.frames.size() != series.size() ||
      std::any_of(k.frames.begin(), k.frames.end(), [](const auto& f) { return f.empty(); }))
    throw bad("lists frames of " + std::to_string(k.frames.size()) + " layers, the scene writes " +
              std::to_string(series.size()));
  if (k.progress.loop_step < 0 || k.progress.frame < 1 || !std::isfinite(k.progress.next_frame_s))
    throw bad("its progress counters are out of range");
  sim::restore_state(s, k.state);
  driver.active = k.tool_active;
  driver.routes = k.routes;
  driver.touched = k.touched;
  driver.loads = k.loads;
  for (size_t l = 0; l < series.size(); ++l) series[l].files = k.frames[l];
}

}  // namespace

int run_run(const RunArgs& a) {
  const auto t_start = Clock::now();
  if (a.realtime && !(a.rate_hz > 0.0 && a.rate_hz <= 1e6))
    throw invalid_input("--rate", "must be in (0, 1e6] steps per second");
  if (a.checkpoint_every < 0) throw invalid_input("--checkpoint-every", "must be >= 0 steps");
  if (a.stop_after_steps < 0) throw invalid_input("--stop-after", "must be >= 0 steps");
  // A resumed run reads its checkpoint first: it names the scene when none is given.
  std::optional<io::RunCheckpoint> resume;
  if (!a.resume.empty()) resume = io::load_checkpoint(a.resume);
  const std::string scene_path = !a.scene.empty() ? a.scene
                                 : resume         ? resume->scene_path
                                                  : std::string();
  if (a.paper && !a.scene.empty())
    throw invalid_input("--paper", "cannot be given with a scene file (" + a.scene +
                                       "): the scene sets the model and material");
  io::Scene scene = scene_path.empty() ? (a.paper ? io::paper_scene() : io::Scene{})
                                       : io::load_scene(scene_path);
  const uint32_t scene_crc = scene_path.empty() ? 0 : io::file_crc(scene_path);
  if (resume && scene_crc != resume->scene_crc) {
    const auto name = [](const std::string& p) { return p.empty() ? "the default scene" : p; };
    throw invalid_input(a.resume, "was written for " + name(resume->scene_path) + ", and " +
                                      name(scene_path) +
                                      " is not that scene as it was: resume with the same scene");
  }
  check_output_folder(a.output);
  const bool tty = ::isatty(2);
  const ProgressFn progress = a.quiet ? ProgressFn{} : stderr_progress(a.verbose);

  if (a.realtime && scene.solver.dt_s != 1.0 / a.rate_hz) {
    // Real time: the simulated clock follows the wall clock, one step of 1 / rate per tick.
    log::info("{}: --realtime at {:g} Hz steps dt = {:g} s (the scene says {:g} s)", scene.source,
              a.rate_hz, 1.0 / a.rate_hz, scene.solver.dt_s);
    scene.solver.dt_s = 1.0 / a.rate_hz;
  }

  // 1. The model, and the scene checked against it, before anything is written.
  io::ReadyScene ready = io::make_ready_scene(scene, volume_read_options, progress);
  const double model_seconds = seconds_since(t_start);
  scene = ready.scene;
  const io::SceneSetup& setup = ready.setup;
  const io::MaterialReport& material = setup.material;
  const Model& m = *ready.model;
  const uint32_t model_crc = io::model_fingerprint(m);
  if (resume && model_crc != resume->model_crc)
    throw invalid_input(a.resume, "was written for another model than the one " + ready.source +
                                      " gives now (its fingerprint differs)");
  sim::Simulation s = io::make_scene_simulation(ready);
  if (setup.fixed.empty() && setup.support.nodes.empty() &&
      scene.material.anchor_stiffness_n_per_m == 0.0 && scene.solver.mode == sim::Mode::kGlobal)
    log::warn(
        "{}: no fixed nodes, no support and no anchor springs: a pushed model drifts as a rigid "
        "body and may not come back to rest",
        scene.source);
  interact::ToolDriver driver = io::make_tool_driver(scene);

  // 2. Outputs.
  const fs::path out(a.output);
  create_folder(out / "frames");
  remove_stale_frames(out / "frames", resume ? resume->progress.frame : 0);
  std::vector<Series> series;
  for (int32_t k = 0; k < (scene.output.all_layers ? m.layer_count() : 1); ++k) {
    Series& se = series.emplace_back();
    se.name = k == 0 ? "skin" : "layer" + std::to_string(k);
    se.layer = k;
    se.mesh = model::layer_mesh(m, k);
  }
  // Everything the loop accumulates, which a checkpoint saves and a resume restores whole.
  io::RunProgress so_far;
  so_far.metrics_csv = kMetricsHeader;
  so_far.next_frame_s = scene.output.frame_interval_s;
  auto write_frames = [&] {
    for (Series& se : series) write_frame(se, s, out, so_far.frame, scene.output.obj);
    ++so_far.frame;
  };

  // 3. Step until every tool has let go and the model is at rest. A tool that never ends is
  // followed until the model rests under its load. One quiet step is not enough: velocities
  // pass through zero when a tool is released and at the turning points of an oscillation, so
  // the test must hold for a settling window (sim::quiet_steps: 0.1 s, at least 3 steps).
  interact::RestWatch rest = interact::rest_watch(s, driver);
  rest.quiet.streak = so_far.quiet_streak;  // resumed from a checkpoint
  const double interval = scene.output.frame_interval_s;

  std::vector<double> step_us;
  step_us.reserve(static_cast<size_t>(std::min<int64_t>(scene.solver.max_steps, 1 << 20)));
  double first_settle_speed = 0.0;
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
  if (resume) {
    restore_run(*resume, a.resume, s, driver, series);
    so_far = resume->progress;
    if (resume->threads != omp_get_max_threads())
      log::warn(
          "{}: written with {} threads, resumed with {}: sums may round differently; set "
          "OMP_NUM_THREADS={} to continue bit for bit",
          a.resume, resume->threads, omp_get_max_threads(), resume->threads);
  } else {
    write_frames();
  }
  // The checkpoint: the whole state after the step just taken, replaced atomically each time.
  const std::string checkpoint_path = (out / "checkpoint.lmck").string();
  auto write_checkpoint = [&](int64_t loop_step) {
    io::RunCheckpoint ck;
    ck.scene_path = scene_path.empty() ? "" : fs::absolute(scene_path).string();
    ck.scene_crc = scene_crc;
    ck.model_crc = model_crc;
    ck.threads = omp_get_max_threads();
    ck.state = sim::capture_state(s);
    ck.tool_active = driver.active;
    ck.routes = driver.routes;
    ck.touched = driver.touched;
    ck.loads = driver.loads;
    ck.progress = so_far;
    ck.progress.loop_step = loop_step;
    for (const Series& se : series) ck.frames.push_back(se.files);
    io::save_checkpoint(ck, checkpoint_path);
  };
  bool stopped = false;
  // A step that not even backward Euler can take leaves the state as it was. A few in a row mean
  // the load or dt is beyond the model: stop, keep what was computed, and say so.
  constexpr int64_t kMaxFailedSteps = 10;
  int64_t failed_streak = 0;
  bool unstable = false;
  const int64_t first_step = so_far.loop_step;
  const int64_t steps_at_start = s.steps;  // after a resume: this run's share is what counts
  const double start_time_s = s.time_s;
  for (int64_t k = first_step; k < scene.solver.max_steps; ++k) {
    const double start_s = s.time_s;
    const auto t0 = Clock::now();
    interact::apply_tools(s, driver);
    st = sim::step(s);
    const double us = std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
    step_us.push_back(us);
    const Eigen::Vector3d reaction = interact::reaction_force(s, driver.loads);
    so_far.max_reaction_mn = std::max(so_far.max_reaction_mn, reaction.norm());
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
    so_far.max_displacement_mm = std::max(so_far.max_displacement_mm, st.max_displacement_mm);
    so_far.max_abs_volume_change_pct =
        std::max(so_far.max_abs_volume_change_pct, std::abs(st.volume_change_pct));
    converged = rest.update(start_s, st);
    so_far.quiet_streak = rest.quiet.streak;

    const bool frame_due = interval > 0.0 && s.time_s >= so_far.next_frame_s - 1e-9 * interval;
    if (frame_due) {
      write_frames();
      while (so_far.next_frame_s <= s.time_s + 1e-9 * interval) so_far.next_frame_s += interval;
    }
    if (scene.output.metrics_every_step || frame_due || converged ||
        k + 1 == scene.solver.max_steps)
      append_metrics(so_far.metrics_csv, s.time_s, st, us, active, reaction);
    if (converged) break;
    failed_streak = st.failed ? failed_streak + 1 : 0;
    if (failed_streak >= kMaxFailedSteps) {
      unstable = true;
      break;
    }
    if (a.checkpoint_every > 0 && (k + 1) % a.checkpoint_every == 0) write_checkpoint(k + 1);
    if (a.stop_after_steps > 0 && k + 1 - first_step >= a.stop_after_steps) {
      if (a.checkpoint_every <= 0 || (k + 1) % a.checkpoint_every != 0) write_checkpoint(k + 1);
      stopped = true;
      break;
    }

    if (progress && seconds_since(last_report) >= report_every_s) {
      last_report = Clock::now();
      // Before release: time towards the last release. After: orders of magnitude of the
      // largest speed still to lose before the rest speed.
      double fraction = 0.0;
      const double settle_from = rest.settle_from_s;
      if (start_s < settle_from) {
        fraction = settle_from > 0.0 ? 0.5 * s.time_s / settle_from : 0.0;
      } else {
        if (first_settle_speed == 0.0) first_settle_speed = std::max(st.max_speed_mm_per_s, 1e-300);
        const double span = std::log(first_settle_speed / scene.solver.rest_speed_mm_per_s);
        const double done = std::log(first_settle_speed / std::max(st.max_speed_mm_per_s, 1e-300));
        fraction = 0.5 + 0.5 * (span > 0.0 ? std::clamp(done / span, 0.0, 0.99) : 0.99);
      }
      report_progress(progress,
                      fmt::format("simulating: t = {:.2f} s, step {}, fastest node {:.2g} mm/s",
                                  s.time_s, s.steps, st.max_speed_mm_per_s),
                      std::min(fraction, 0.99));
    }
  }
  if (!stopped && series.front().files.back().first != s.time_s) write_frames();  // final state
  report_progress(progress, fmt::format("simulated {:.2f} s in {} steps", s.time_s, s.steps), 1.0);
  if (stopped)
    log::info(
        "stopped after {} steps as asked (--stop-after); continue with: lamina run "
        "--resume {} -o {}",
        a.stop_after_steps, checkpoint_path, a.output);
  else if (!converged && !unstable)
    log::warn("{}: not at rest after solver.max_steps = {} steps ({:.2f} s simulated)",
              scene.source, scene.solver.max_steps, s.time_s);

  // 4. Results.
  write_file_atomically((out / "metrics.csv").string(),
                        [&](std::ostream& f) { f << so_far.metrics_csv; });
  for (const Series& se : series) write_pvd(se, out);
  io::RunSummary sum;
  sum.scene = scene.source;
  sum.model = ready.source;
  sum.material = material;
  sum.converged = converged;
  sum.stopped = stopped;
  sum.unstable = unstable;
  sum.steps = s.steps;
  sum.sim_seconds = s.time_s;
  sum.model_seconds = model_seconds;
  sum.max_displacement_mm = so_far.max_displacement_mm;
  sum.max_abs_volume_change_pct = so_far.max_abs_volume_change_pct;
  sum.final_rest_error_mm = max_rest_distance(s);
  sum.final_volume_change_pct = st.volume_change_pct;
  sum.recoveries = s.recoveries;
  sum.integrator = scene.solver.integrator;
  sum.mode = scene.solver.mode;
  sum.dt_s = scene.solver.dt_s;
  sum.nodes = m.node_count();
  sum.springs = static_cast<int64_t>(m.springs.size());
  sum.layers = m.layer_count();
  sum.fixed_nodes = static_cast<int32_t>(setup.fixed.size());
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
  sum.frames = so_far.frame;
  sum.max_reaction_n = so_far.max_reaction_mn / 1000.0;
  if (a.realtime) {
    sum.realtime = true;
    sum.rate_hz = a.rate_hz;
    const double wall = std::max(seconds_since(loop_start), 1e-9);
    sum.achieved_rate_hz = static_cast<double>(s.steps - steps_at_start) / wall;
    sum.real_time_factor = (s.time_s - start_time_s) / wall;
    sum.kept_up = sum.real_time_factor >= 0.95;
    if (!sum.kept_up)
      log::warn("{}: the machine did not keep up with real time: {:.2f} simulated seconds per "
                "wall second ({:.0f} of {:.0f} steps/s); a smaller model or a lower --rate keeps "
                "up",
                scene.source, sum.real_time_factor, sum.achieved_rate_hz, a.rate_hz);
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

  if (unstable) {
    double largest_n = 0.0;
    for (const interact::Tool& t : scene.tools) largest_n = std::max(largest_n, t.force_mn.norm());
    throw Error(
        ErrorKind::kUnstable,
        fmt::format("{}: the simulation could not take a step at t = {:.3g} s even after "
                    "rolling back to backward Euler ({} steps in a row): a tool force "
                    "(largest {:.3g} N) or dt = {:.3g} s is beyond what this model can take; "
                    "lower it (the run until then is in {})",
                    scene.source, s.time_s, kMaxFailedSteps, largest_n / 1000.0, scene.solver.dt_s,
                    a.output));
  }
  if (a.json) {
    std::cout << json << "\n";
  } else {
    std::cout << fmt::format(
        "lamina run: {} on {} ({} nodes, {} layers)\n"
        "  {} after {} steps ({:.2f} s simulated) in {:.2f} s; {:.0f} steps/s\n"
        "  max displacement {:.3g} mm, max |volume change| {:.3g}%, final rest error {:.3g} mm\n"
        "  wrote {}: metrics.csv, summary.json, {}.pvd ({} frames)\n",
        scene.source, ready.source, sum.nodes, sum.layers,
        converged ? "converged"
        : stopped ? "stopped for a resume"
                  : "NOT converged",
        sum.steps, sum.sim_seconds, sum.wall_seconds, sum.steps_per_second, sum.max_displacement_mm,
        sum.max_abs_volume_change_pct, sum.final_rest_error_mm, a.output,
        series.size() > 1 ? "skin.pvd, layer*" : "skin", so_far.frame);
    if (sum.realtime)
      std::cout << fmt::format(
          "  realtime: {:.0f} steps/s achieved of {:.0f} ({:.2f}x real time{}); step start late by "
          "{:.0f} us at worst, {:.0f} us at the 99th percentile\n",
          sum.achieved_rate_hz, sum.rate_hz, sum.real_time_factor,
          sum.kept_up ? "" : ", BEHIND", sum.worst_jitter_us, sum.p99_jitter_us);
  }
  return 0;
}

}  // namespace lamina::cli
