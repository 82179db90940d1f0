// `lamina run`: a scene's tools push the organ, it responds; frames, metrics and a summary are
// written, and with --checkpoint-every the whole state, so that a stopped run resumes bit for bit.
#include <fmt/format.h>
#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <iostream>
#include <map>
#include <numeric>
#include <optional>
#include <regex>
#include <set>
#include <thread>

#include "commands.h"
#include "lamina/core/atomic_file.h"
#include "lamina/core/clock.h"
#include "lamina/core/error.h"
#include "lamina/core/keep_freed_memory.h"
#include "lamina/core/log.h"
#include "lamina/interact/pacer.h"
#include "lamina/interact/run_tools.h"
#include "lamina/interact/scalpel.h"
#include "lamina/interact/tools.h"
#include "lamina/io/checkpoint.h"
#include "lamina/io/mesh_file.h"
#include "lamina/io/scene.h"
#include "lamina/io/summary_json.h"
#include "lamina/io/world_scene.h"
#include "lamina/model/cut_tetrahedra.h"
#include "lamina/model/embed_surface.h"
#include "lamina/model/structure_colors.h"
#include "lamina/model/summarize_model.h"
#include "lamina/sim/simulation.h"
#include "lamina/world/cut_body.h"
#include "lamina/world/world.h"
#include "scalpel_checkpoint.h"
#include "series_files.h"

namespace lamina::cli {
namespace {

namespace fs = std::filesystem;
// One VTK time series: a layer's or an embedded surface's mesh written at every frame, listed in
// NAME.pvd.
struct Series {
  std::string name;       // "skin", "layer1", ..., then the embedded surfaces' ("vessels")
  int32_t layer = 0;      // the layer shown, when embedded < 0
  int32_t embedded = -1;  // else the embedded surface shown (Model::embedded), at W x
  int32_t piece = -1;     // a cut's piece k (largest first): the skin's triangles on it
  SurfaceMesh mesh;       // connectivity fixed, positions updated per frame (buffer reused)
  model::Rgb8 color = model::kOrganColor;             // its `color` point array, for ParaView
  std::vector<std::pair<double, std::string>> files;  // time (s), path relative to OUTDIR
};

void write_frame(Series& series, const sim::Simulation& s, const fs::path& out, int32_t index,
                 bool obj) {
  if (series.embedded >= 0) {
    model::embedded_positions(s.model().embedded[static_cast<size_t>(series.embedded)], s.x,
                              series.mesh.V);
  } else {
    const ModelLayer& layer = s.model().layers[static_cast<size_t>(series.layer)];
    series.mesh.V = s.x.middleRows(layer.first_node, layer.node_count);
  }
  const std::string stem = fmt::format("frames/{}_{:06d}", series.name, index);
  io::write_mesh(series.mesh, (out / (stem + ".vtp")).string(), series.color);
  if (obj) io::write_mesh(series.mesh, (out / (stem + ".obj")).string());
  series.files.emplace_back(s.time_s, stem + ".vtp");
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
  // The first series has every frame (a cut's series start with it, and may have none yet).
  if (k.frames.size() != series.size() || k.frames.empty() || k.frames.front().empty())
    throw bad("lists frames of " + std::to_string(k.frames.size()) +
              " series, the scene and model write " + std::to_string(series.size()));
  // Series in the checkpoint's order (a cut adds them as it goes; a resume adds them at once).
  if (!k.series_names.empty()) {
    std::vector<Series> ordered;
    for (const std::string& name : k.series_names) {
      const auto it = std::find_if(series.begin(), series.end(),
                                   [&](const Series& se) { return se.name == name; });
      if (it == series.end()) throw bad("lists frames of a series " + name + " this run has not");
      ordered.push_back(std::move(*it));
      series.erase(it);
    }
    series = std::move(ordered);
  }
  if (k.progress.loop_step < 0 || k.progress.frame < 1 || !std::isfinite(k.progress.next_frame_s))
    throw bad("its progress counters are out of range");
  sim::restore_state(s, k.state);
  driver.active = k.tool_active;
  driver.routes = k.routes;
  driver.touched = k.touched;
  driver.loads = k.loads;
  for (size_t l = 0; l < series.size(); ++l) series[l].files = k.frames[l];
}

// The scene a run is of: the file given, the one a checkpoint names, or the default (the
// paper's with --paper). A resume must find the scene file as it was.
struct RunScene {
  io::Scene scene;
  std::string path;       // empty for the built-in scenes
  uint32_t file_crc = 0;  // CRC-32 of the scene file (0 for the built-in scenes)
};

RunScene load_run_scene(const RunArgs& a, const std::optional<io::RunCheckpoint>& resume) {
  RunScene r;
  r.path = !a.scene.empty() ? a.scene : resume ? resume->scene_path : std::string();
  if (a.paper && !a.scene.empty())
    throw invalid_input("--paper", "cannot be given with a scene file (" + a.scene +
                                       "): the scene sets the model and material");
  r.scene = r.path.empty() ? (a.paper ? io::paper_scene() : io::Scene{}) : io::load_scene(r.path);
  r.file_crc = r.path.empty() ? 0 : io::file_crc(r.path);
  if (resume && r.file_crc != resume->scene_crc) {
    const auto name = [](const std::string& p) { return p.empty() ? "the default scene" : p; };
    throw invalid_input(a.resume, "was written for " + name(resume->scene_path) + ", and " +
                                      name(r.path) +
                                      " is not that scene as it was: resume with the same scene");
  }
  if (a.realtime && r.scene.solver.dt_s != 1.0 / a.rate_hz) {
    // Real time: the simulated clock follows the wall clock, one step of 1 / rate per tick.
    log::info("{}: --realtime at {:g} Hz steps dt = {:g} s (the scene says {:g} s)", r.scene.source,
              a.rate_hz, 1.0 / a.rate_hz, r.scene.solver.dt_s);
    r.scene.solver.dt_s = 1.0 / a.rate_hz;
  }
  return r;
}

// The skin's triangles on each piece of a cut model (its connected parts of the tetrahedra),
// the pieces largest first (by tetrahedra).
std::vector<Eigen::MatrixX3i> skin_by_piece(const Model& m) {
  std::vector<int32_t> root(static_cast<size_t>(m.node_count()));
  std::iota(root.begin(), root.end(), 0);
  const auto find = [&](int32_t a) {
    while (root[a] != a) a = root[a] = root[root[a]];
    return a;
  };
  for (Eigen::Index t = 0; t < m.tets.size(); ++t)
    for (int k = 1; k < 4; ++k) root[find(m.tets.T(t, k))] = find(m.tets.T(t, 0));
  std::map<int32_t, int64_t> size;
  for (Eigen::Index t = 0; t < m.tets.size(); ++t) ++size[find(m.tets.T(t, 0))];
  std::vector<std::pair<int64_t, int32_t>> order;
  for (const auto& [r, n] : size) order.emplace_back(-n, r);
  std::sort(order.begin(), order.end());
  std::map<int32_t, size_t> index;
  for (size_t k = 0; k < order.size(); ++k) index[order[k].second] = k;
  const SurfaceMesh skin = model::layer_mesh(m, 0);
  std::vector<std::vector<Eigen::RowVector3i>> rows(order.size());
  for (Eigen::Index f = 0; f < skin.F.rows(); ++f) {
    const auto it = index.find(find(m.layers[0].first_node + skin.F(f, 0)));
    if (it != index.end()) rows[it->second].push_back(skin.F.row(f));
  }
  std::vector<Eigen::MatrixX3i> out(order.size());
  for (size_t k = 0; k < order.size(); ++k) {
    out[k].resize(static_cast<Eigen::Index>(rows[k].size()), 3);
    for (size_t r = 0; r < rows[k].size(); ++r)
      out[k].row(static_cast<Eigen::Index>(r)) = rows[k][r];
  }
  return out;
}

// What the run writes as it goes: a VTK series per layer, the metrics, checkpoints.
struct RunOutputs {
  fs::path out;
  std::vector<Series> series;
  bool obj = false;
  bool embedded = true;  // scene.output.embedded: a series per embedded surface

  RunOutputs(const fs::path& folder, const io::Scene& scene, const Model& m, int32_t keep_frames)
      : out(folder), obj(scene.output.obj), embedded(scene.output.embedded) {
    std::set<std::string> names;
    for (int32_t k = 0; k < (scene.output.all_layers ? m.layer_count() : 1); ++k) {
      Series& se = series.emplace_back();
      se.name = k == 0 ? "skin" : "layer" + std::to_string(k);
      se.layer = k;
      se.mesh = model::layer_mesh(m, k);
      names.insert(se.name);
    }
    const std::vector<model::Rgb8> colors = model::structure_colors(m);
    for (size_t k = 0; k < m.embedded.size(); ++k) {
      const bool skin = static_cast<int32_t>(k) == model::display_skin_index(m);
      if (!(skin ? scene.output.display_skin : scene.output.embedded)) continue;
      Series& se = series.emplace_back();
      se.name = series_name(m.embedded[k].name, names);
      se.embedded = static_cast<int32_t>(k);
      se.mesh.V = m.embedded[k].V;
      se.mesh.F = m.embedded[k].F;
      se.color = colors[k];
      names.insert(se.name);
    }
    create_folder(out / "frames");
    std::set<std::string> stale = names;
    stale.insert(model::kWoundName);  // a cut's wound series, which starts at the first cut
    remove_stale_frames(out / "frames", stale, keep_frames);
  }

  void write_frames(const sim::Simulation& s, io::RunProgress& so_far) {
    for (Series& se : series) write_frame(se, s, out, so_far.frame, obj);
    ++so_far.frame;
  }

  // A cut changed the layers' triangles (a triangle the cut divides is on both sides' copies),
  // split the embedded surfaces along the blade (new vertices and triangles, sections capped)
  // and added to the wound (an embedded surface of its own, whose series starts with the first
  // cut).
  void follow_cut(const Model& m) {
    const std::vector<Eigen::MatrixX3i> pieces = skin_by_piece(m);
    for (size_t k = 0; k < pieces.size() && pieces.size() > 1; ++k)
      if (std::none_of(series.begin(), series.end(),
                       [&](const Series& se) { return se.piece == static_cast<int32_t>(k); })) {
        Series& se = series.emplace_back();
        se.name = "piece" + std::to_string(k + 1);
        se.piece = static_cast<int32_t>(k);
      }
    for (Series& se : series)
      se.mesh.F = se.piece >= 0     ? (static_cast<size_t>(se.piece) < pieces.size()
                                           ? pieces[static_cast<size_t>(se.piece)]
                                           : Eigen::MatrixX3i(0, 3))
                  : se.embedded < 0 ? model::layer_mesh(m, se.layer).F
                                    : m.embedded[static_cast<size_t>(se.embedded)].F;
    if (!embedded) return;
    const std::vector<model::Rgb8> colors = model::structure_colors(m);
    for (size_t k = 0; k < m.embedded.size(); ++k) {
      if (static_cast<int32_t>(k) == model::display_skin_index(m) ||
          std::any_of(series.begin(), series.end(),
                      [&](const Series& se) { return se.embedded == static_cast<int32_t>(k); }))
        continue;
      std::set<std::string> names;
      for (const Series& se : series) names.insert(se.name);
      Series& se = series.emplace_back();
      se.name = series_name(m.embedded[k].name, names);
      se.embedded = static_cast<int32_t>(k);
      se.mesh.F = m.embedded[k].F;
      se.color = colors[k];
    }
  }

  bool frame_written_at(double time_s) const { return series.front().files.back().first == time_s; }

  void write_results(const io::RunProgress& so_far) {
    write_file_atomically((out / "metrics.csv").string(),
                          [&](std::ostream& f) { f << so_far.metrics_csv; });
    for (const Series& se : series) write_pvd(out, se.name, se.files);
  }
};

// The scalpels of a run and what each cut did (the model they cut is the body's).
struct Cutting {
  interact::ScalpelDriver scalpels;
  std::vector<interact::CutEvent> events{};
};

// How the stepping loop ended and what it measured along the way.
struct LoopResult {
  bool converged = false;
  bool stopped = false;  // --stop-after: a checkpoint to resume from was written
  sim::Instability unstable = sim::Instability::kNone;  // why the run stopped early
  sim::StepStats last;
  std::vector<double> step_us;      // each step's wall time, tool routing included
  std::vector<double> lateness_us;  // --realtime: each step's start after its tick
  double wall_s = 0.0;              // the loop's wall time
  int64_t steps = 0;                // steps this run took (a resumed run's share)
  double sim_s = 0.0;               // simulated time this run covered
};

// Progress towards the end of a run: before the last release, time towards it; after, the
// orders of magnitude of the largest speed still to lose before the rest speed.
struct RunProgressReport {
  ProgressFn progress;
  double every_s = 2.0;
  Clock::time_point last = Clock::now();
  double first_settle_speed = 0.0;

  void update(const sim::Simulation& s, const sim::StepStats& st, double start_s,
              double settle_from_s, double rest_speed) {
    if (!progress || seconds_since(last) < every_s) return;
    last = Clock::now();
    double fraction = 0.0;
    if (start_s < settle_from_s) {
      fraction = settle_from_s > 0.0 ? 0.5 * s.time_s / settle_from_s : 0.0;
    } else {
      if (first_settle_speed == 0.0) first_settle_speed = std::max(st.max_speed_mm_per_s, 1e-300);
      const double span = std::log(first_settle_speed / rest_speed);
      const double done = std::log(first_settle_speed / std::max(st.max_speed_mm_per_s, 1e-300));
      fraction = 0.5 + 0.5 * (span > 0.0 ? std::clamp(done / span, 0.0, 0.99) : 0.99);
    }
    report_progress(progress,
                    fmt::format("simulating: t = {:.2f} s, step {}, fastest node {:.2g} mm/s",
                                s.time_s, s.steps, st.max_speed_mm_per_s),
                    std::min(fraction, 0.99));
  }
};

// Steps until every tool has let go and the model is at rest (interact::RestWatch: a tool that
// never ends is followed until the model rests under its load), or until max_steps, too many
// an unstable simulation (sim::Instability), or --stop-after. Frames, metrics and checkpoints are
// written as it goes.
LoopResult step_run(const RunArgs& a, const io::Scene& scene, world::World& w, RunOutputs& outputs,
                    io::RunProgress& so_far, const std::function<void(int64_t)>& write_checkpoint,
                    RunProgressReport& report, Cutting& cutting) {
  const world::BodyId organ = world::body_ids(w).front();
  sim::Simulation& s = world::body(w, organ).sim;
  interact::ToolDriver& driver = world::body(w, organ).tools;
  world::WorldStepStats stats;
  LoopResult r;
  interact::RestWatch rest = interact::rest_watch(s, driver);
  for (const interact::Scalpel& sc : cutting.scalpels.scalpels)
    rest.settle_from_s = std::max(rest.settle_from_s, sc.end_s);
  rest.quiet.streak = so_far.quiet_streak;  // resumed from a checkpoint
  const double interval = scene.output.frame_interval_s;
  r.step_us.reserve(static_cast<size_t>(std::min<int64_t>(scene.solver.max_steps, 1 << 20)));
  if (a.realtime) r.lateness_us.reserve(r.step_us.capacity());
  // --realtime: a haptic loop, each step starting at its tick.
  interact::Pacer pacer(a.realtime ? a.rate_hz : 0.0);
  pacer.restart();
  const auto loop_start = Clock::now();
  const int64_t first_step = so_far.loop_step;
  const int64_t steps_at_start = s.steps;
  const double time_at_start = s.time_s;
  for (int64_t k = first_step; k < scene.solver.max_steps; ++k) {
    if (a.realtime) r.lateness_us.push_back(pacer.lateness_us());
    const double start_s = s.time_s;
    const auto t0 = Clock::now();
    if (!cutting.scalpels.scalpels.empty()) {
      for (interact::CutEvent& e : world::advance_scalpels(w, organ, cutting.scalpels)) {
        for (const model::StructureCut& c : e.report.structures_cut)
          log::warn(
              "t = {:.3f} s: the scalpel cut {} across at ({:.1f}, {:.1f}, {:.1f}) mm, "
              "{:.1f} mm wide{}",
              e.time_s, c.name, c.position_mm.x(), c.position_mm.y(), c.position_mm.z(),
              c.diameter_mm, c.closed ? "" : " (the blade stopped inside it)");
        if (e.report.cut_tets > 0)
          log::debug("t = {:.3f} s: cut {} tetrahedra, {} new nodes, {} piece(s), in {:.1f} ms",
                     e.time_s, e.report.cut_tets, e.report.new_nodes, e.report.pieces.size(),
                     1e3 * e.seconds);
        if (e.report.cut_tets == 0 && e.report.surfaces_split)
          log::debug("t = {:.3f} s: past the tissue, the structures beside it split, in {:.1f} ms",
                     e.time_s, 1e3 * e.seconds);
        if (e.report.changed()) outputs.follow_cut(*world::body(w, organ).model);
        cutting.events.push_back(std::move(e));
      }
    }
    world::step(w, stats);  // the tools, then the solve: as the simulation alone
    r.last = stats.bodies.front().sim;
    const double us = std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
    r.step_us.push_back(us);
    const Eigen::Vector3d reaction = interact::tools_reaction(s, driver);
    so_far.max_reaction_mn = std::max(so_far.max_reaction_mn, reaction.norm());
    const int active = static_cast<int>(std::count(driver.active.begin(), driver.active.end(), 1));
    so_far.max_displacement_mm = std::max(so_far.max_displacement_mm, r.last.max_displacement_mm);
    so_far.max_abs_volume_change_pct =
        std::max(so_far.max_abs_volume_change_pct, std::abs(r.last.volume_change_pct));
    r.converged = rest.update(start_s, r.last);
    so_far.quiet_streak = rest.quiet.streak;

    const bool frame_due = interval > 0.0 && s.time_s >= so_far.next_frame_s - 1e-9 * interval;
    if (frame_due) {
      outputs.write_frames(s, so_far);
      while (so_far.next_frame_s <= s.time_s + 1e-9 * interval) so_far.next_frame_s += interval;
    }
    if (scene.output.metrics_every_step || frame_due || r.converged ||
        k + 1 == scene.solver.max_steps)
      append_metrics(so_far.metrics_csv, s.time_s, r.last, us, active, reaction);
    if (r.converged) break;
    if (r.last.unstable != sim::Instability::kNone) {
      r.unstable = r.last.unstable;
      break;
    }
    if (a.checkpoint_every > 0 && (k + 1) % a.checkpoint_every == 0) write_checkpoint(k + 1);
    if (a.stop_after_steps > 0 && k + 1 - first_step >= a.stop_after_steps) {
      if (a.checkpoint_every <= 0 || (k + 1) % a.checkpoint_every != 0) write_checkpoint(k + 1);
      r.stopped = true;
      break;
    }
    report.update(s, r.last, start_s, rest.settle_from_s, scene.solver.rest_speed_mm_per_s);
    if (a.realtime) std::this_thread::sleep_until(pacer.advance());
  }
  r.wall_s = std::max(seconds_since(loop_start), 1e-9);
  r.steps = s.steps - steps_at_start;
  r.sim_s = s.time_s - time_at_start;
  return r;
}

// Step times and, for --realtime, how well the loop kept to the wall clock.
void summarize_timing(LoopResult& loop, const RunArgs& a, io::RunSummary& sum) {
  if (!loop.step_us.empty()) {
    double total = 0.0;
    for (double u : loop.step_us) total += u;
    sum.mean_step_us = total / static_cast<double>(loop.step_us.size());
    sum.steps_per_second =
        total > 0.0 ? 1e6 * static_cast<double>(loop.step_us.size()) / total : 0.0;
    const auto mid = loop.step_us.begin() + static_cast<std::ptrdiff_t>(loop.step_us.size() / 2);
    std::nth_element(loop.step_us.begin(), mid, loop.step_us.end());
    sum.median_step_us = *mid;
  }
  if (!a.realtime) return;
  sum.realtime = true;
  sum.rate_hz = a.rate_hz;
  sum.achieved_rate_hz = static_cast<double>(loop.steps) / loop.wall_s;
  sum.real_time_factor = loop.sim_s / loop.wall_s;
  sum.kept_up = sum.real_time_factor >= 0.95;
  if (!sum.kept_up)
    log::warn(
        "{}: the machine did not keep up with real time: {:.2f} simulated seconds per "
        "wall second ({:.0f} of {:.0f} steps/s); a smaller model or a lower --rate keeps "
        "up",
        sum.scene, sum.real_time_factor, sum.achieved_rate_hz, a.rate_hz);
  if (!loop.lateness_us.empty()) {
    std::sort(loop.lateness_us.begin(), loop.lateness_us.end());
    sum.worst_jitter_us = loop.lateness_us.back();
    sum.p99_jitter_us = loop.lateness_us[static_cast<size_t>(0.99 * (loop.lateness_us.size() - 1))];
  }
}

// What the scalpels did, for the summary.
void summarize_cuts(const Cutting& c, io::RunSummary& sum) {
  sum.scalpels = static_cast<int32_t>(c.scalpels.scalpels.size());
  if (sum.scalpels == 0) return;
  std::vector<double> ms;
  for (const interact::CutEvent& e : c.events) {
    for (const model::StructureCut& x : e.report.structures_cut)
      sum.structures_cut.push_back({.time_s = e.time_s, .cut = x});
    if (!e.report.changed()) continue;
    // (An event past the tissue that split only the structures beside it is timed as a cut.)
    ms.push_back(1e3 * e.seconds);
    if (e.report.cut_tets == 0) continue;
    ++sum.cuts;
    sum.cut_tets += e.report.cut_tets;
    sum.cut_new_nodes += e.report.new_nodes;
    sum.pieces = e.report.pieces;
  }
  if (!ms.empty()) {
    std::sort(ms.begin(), ms.end());
    sum.median_cut_ms = ms[ms.size() / 2];
    sum.max_cut_ms = ms.back();
  }
}

void print_run(const io::RunSummary& sum, const std::string& output,
               const std::vector<Series>& series, int32_t frames) {
  std::string files;
  for (const Series& se : series)
    if (se.layer == 0 || se.embedded >= 0) files += (files.empty() ? "" : ", ") + se.name + ".pvd";
  if (series.size() > 1 && series[1].embedded < 0) files += ", layer*.pvd";
  std::cout << fmt::format(
      "lamina run: {} on {} ({} nodes, {} layers)\n"
      "  {} after {} steps ({:.2f} s simulated) in {:.2f} s; {:.0f} steps/s\n"
      "  max displacement {:.3g} mm, max |volume change| {:.3g}%, final rest error {:.3g} mm\n"
      "  wrote {}: metrics.csv, summary.json, {} ({} frames)\n",
      sum.scene, sum.model, sum.nodes, sum.layers,
      sum.converged ? "converged"
      : sum.stopped ? "stopped for a resume"
                    : "NOT converged",
      sum.steps, sum.sim_seconds, sum.wall_seconds, sum.steps_per_second, sum.max_displacement_mm,
      sum.max_abs_volume_change_pct, sum.final_rest_error_mm, output, files, frames);
  if (sum.scalpels > 0) {
    std::string pieces;
    for (const model::CutPiece& p : sum.pieces)
      pieces += fmt::format("{}{:.1f} mL", pieces.empty() ? "" : ", ", p.volume_mm3 / 1000.0);
    std::cout << fmt::format(
        "  scalpel: {} cuts, {} tetrahedra divided{}; {} structure(s) cut across\n", sum.cuts,
        sum.cut_tets, pieces.empty() ? "" : "; pieces " + pieces, sum.structures_cut.size());
    for (const io::RunSummary::StructureCrossed& c : sum.structures_cut)
      std::cout << fmt::format(
          "    t = {:.3f} s: {} at ({:.1f}, {:.1f}, {:.1f}) mm, {:.1f} mm wide\n", c.time_s,
          c.cut.name, c.cut.position_mm.x(), c.cut.position_mm.y(), c.cut.position_mm.z(),
          c.cut.diameter_mm);
  }
  if (sum.realtime)
    std::cout << fmt::format(
        "  realtime: {:.0f} steps/s achieved of {:.0f} ({:.2f}x real time{}); step start late by "
        "{:.0f} us at worst, {:.0f} us at the 99th percentile\n",
        sum.achieved_rate_hz, sum.rate_hz, sum.real_time_factor, sum.kept_up ? "" : ", BEHIND",
        sum.worst_jitter_us, sum.p99_jitter_us);
}

// What a run did, for summary.json and the printed summary: all but its timing and wall time.
struct SetupSeconds {
  double model_s = 0.0, prepare_s = 0.0;
};
io::RunSummary summarize_run(const io::ReadyScene& ready, const sim::Simulation& s,
                             const LoopResult& loop, const io::RunProgress& so_far,
                             const Cutting& cutting, SetupSeconds setup) {
  const io::Scene& scene = ready.scene;
  const Model& m = *ready.model;
  io::RunSummary sum;
  sum.scene = scene.source;
  sum.model = ready.source;
  sum.material = ready.setup.material;
  sum.converged = loop.converged;
  sum.stopped = loop.stopped;
  sum.unstable = loop.unstable != sim::Instability::kNone;
  sum.unstable_reason =
      loop.unstable != sim::Instability::kNone ? sim::describe(loop.unstable) : "";
  sum.steps = s.steps;
  sum.sim_seconds = s.time_s;
  sum.model_seconds = setup.model_s;
  sum.setup_stage_seconds = ready.stage_seconds;
  sum.setup_stage_seconds.emplace_back("prepare_solver", setup.prepare_s);
  sum.max_displacement_mm = so_far.max_displacement_mm;
  sum.max_abs_volume_change_pct = so_far.max_abs_volume_change_pct;
  sum.final_rest_error_mm = max_rest_distance(s);
  sum.final_volume_change_pct = loop.last.volume_change_pct;
  sum.recoveries = s.recoveries;
  sum.integrator = scene.solver.integrator;
  sum.mode = scene.solver.mode;
  sum.routing = scene.routing.routing;
  if (scene.solver.integrator == sim::Integrator::kImplicitEuler)
    sum.preconditioner = sim::uses_multigrid(s) ? "multigrid" : "jacobi";
  sum.dt_s = scene.solver.dt_s;
  sum.nodes = s.model().node_count();
  sum.springs = static_cast<int64_t>(s.model().springs.size());
  summarize_cuts(cutting, sum);
  sum.layers = m.layer_count();
  sum.fixed_nodes = static_cast<int32_t>(ready.setup.fixed.size());
  sum.tools = static_cast<int32_t>(scene.tools.size());
  sum.frames = so_far.frame;
  sum.max_reaction_n = so_far.max_reaction_mn / 1000.0;
  return sum;
}

// A run that blew up: when, why, and what to lower (the run until then is in `output`).
Error unstable_error(const io::Scene& scene, const sim::Simulation& s, sim::Instability why,
                     const std::string& output) {
  double largest_n = 0.0;
  for (const interact::Tool& t : scene.tools) largest_n = std::max(largest_n, t.force_mn.norm());
  return Error(ErrorKind::kUnstable,
               fmt::format("{}: unstable at t = {:.3g} s: {}; a tool force (largest {:.3g} N), "
                           "dt = {:.3g} s or the stiffness is beyond what this model can take: "
                           "lower it (the run until then is in {})",
                           scene.source, s.time_s, sim::describe(why), largest_n / 1000.0,
                           scene.solver.dt_s, output));
}

}  // namespace

int run_run(const RunArgs& a) {
  if (!a.scene.empty() && io::is_world_scene_file(a.scene)) return run_world(a);
  const auto t_start = Clock::now();
  if (a.realtime && !(a.rate_hz > 0.0 && a.rate_hz <= 1e6))
    throw invalid_input("--rate", "must be in (0, 1e6] steps per second");
  if (a.checkpoint_every < 0) throw invalid_input("--checkpoint-every", "must be >= 0 steps");
  if (a.stop_after_steps < 0) throw invalid_input("--stop-after", "must be >= 0 steps");
  // A resumed run reads its checkpoint first: it names the scene when none is given.
  std::optional<io::RunCheckpoint> resume;
  if (!a.resume.empty()) resume = io::load_checkpoint(a.resume);
  const RunScene run_scene = load_run_scene(a, resume);
  // A checkpoint holds the tools' loads and a cut model, not what a grasper holds: refused, not
  // resumed wrong.
  if (a.checkpoint_every > 0 || a.stop_after_steps > 0 || resume)
    for (size_t k = 0; k < run_scene.scene.tools.size(); ++k)
      if (run_scene.scene.tools[k].grasp)
        throw invalid_input("tools[" + std::to_string(k) + "].grasp",
                            "a run with a grasper cannot be checkpointed or resumed yet (run it "
                            "without --checkpoint-every and --stop-after)");
  check_output_folder(a.output);
  RunProgressReport report{.progress = a.quiet ? ProgressFn{} : stderr_progress(a.verbose),
                           .every_s = ::isatty(2) ? 0.1 : 2.0};

  // 1. The model, and the scene checked against it, before anything is written.
  const io::ReadyScene ready =
      io::make_ready_scene(run_scene.scene, volume_read_options, report.progress);
  const double model_seconds = seconds_since(t_start);
  const io::Scene& scene = ready.scene;
  const Model& m = *ready.model;  // as built: a scalpel's cuts replace the one simulated
  const uint32_t model_crc = io::model_fingerprint(m);
  if (resume && model_crc != resume->model_crc)
    throw invalid_input(a.resume, "was written for another model than the one " + ready.source +
                                      " gives now (its fingerprint differs)");
  const auto t_prepare = Clock::now();
  // One organ is a world of one body (docs/world.md): its simulation and tools are the body's,
  // stepped by world::step and cut by world::advance_scalpels.
  world::World w =
      world::one_body_world({.name = "organ",
                             .model = ready.model,
                             .simulation = io::make_scene_simulation(ready),
                             .tools = io::make_tool_driver(scene, /*warn_scalpels=*/false)});
  const world::BodyId organ = world::body_ids(w).front();
  sim::Simulation& s = world::body(w, organ).sim;
  interact::ToolDriver& driver = world::body(w, organ).tools;
  const double prepare_seconds = seconds_since(t_prepare);
  if (ready.setup.fixed.empty() && ready.setup.support.nodes.empty() &&
      scene.material.anchor_stiffness_n_per_m == 0.0 && scene.solver.mode == sim::Mode::kGlobal)
    log::warn(
        "{}: no fixed nodes, no support and no anchor springs: a pushed model drifts as a rigid "
        "body and may not come back to rest",
        scene.source);
  Cutting cutting{.scalpels = interact::make_scalpel_driver(scene.scalpels, m, scene.source)};
  // Each cut makes the organ's model and simulation again: their memory reused, not faulted in
  // afresh at every event (as the real-time loops do).
  if (!scene.scalpels.empty()) keep_freed_memory();

  // 2. Outputs, and the state a resume continues from. Everything the loop accumulates is in
  // so_far, which a checkpoint saves and a resume restores whole.
  RunOutputs outputs(a.output, scene, m, resume ? resume->progress.frame : 0);
  io::RunProgress so_far;
  so_far.metrics_csv = kMetricsHeader;
  so_far.next_frame_s = scene.output.frame_interval_s;
  if (resume) {
    if (resume->scalpels.has_value() != !cutting.scalpels.scalpels.empty())
      throw invalid_input(a.resume, "was written for a run " +
                                        std::string(resume->scalpels ? "with" : "without") +
                                        " scalpels: resume with the scene it was written for");
    if (resume->scalpels) {
      // The cuts made again: the body's model.
      std::shared_ptr<const Model>& cut = world::body(w, organ).model;
      restore_scalpels(*resume->scalpels, a.resume, ready.model, cut, cutting.scalpels,
                       cutting.events, s, driver);
      if (cut != ready.model) outputs.follow_cut(*cut);
    }
    restore_run(*resume, a.resume, s, driver, outputs.series);
    so_far = resume->progress;
    if (resume->threads != omp_get_max_threads())
      log::warn(
          "{}: written with {} threads, resumed with {}: sums may round differently; set "
          "OMP_NUM_THREADS={} to continue bit for bit",
          a.resume, resume->threads, omp_get_max_threads(), resume->threads);
  } else {
    outputs.write_frames(s, so_far);
  }
  // The checkpoint: the whole state after the step just taken, replaced atomically each time.
  const std::string checkpoint_path = (outputs.out / "checkpoint.lmck").string();
  const auto write_checkpoint = [&](int64_t loop_step) {
    io::RunCheckpoint ck;
    ck.scene_path = run_scene.path.empty() ? "" : fs::absolute(run_scene.path).string();
    ck.scene_crc = run_scene.file_crc;
    ck.model_crc = model_crc;
    ck.threads = omp_get_max_threads();
    ck.state = sim::capture_state(s);
    ck.tool_active = driver.active;
    ck.routes = driver.routes;
    ck.touched = driver.touched;
    ck.loads = driver.loads;
    ck.progress = so_far;
    ck.progress.loop_step = loop_step;
    for (const Series& se : outputs.series) {
      ck.frames.push_back(se.files);
      ck.series_names.push_back(se.name);
    }
    if (!cutting.scalpels.scalpels.empty())
      ck.scalpels = capture_scalpels(ready.model, world::body(w, organ).model, cutting.scalpels,
                                     cutting.events, s, driver);
    io::save_checkpoint(ck, checkpoint_path);
  };

  // 3. Step.
  LoopResult loop = step_run(a, scene, w, outputs, so_far, write_checkpoint, report, cutting);
  if (!loop.stopped && !outputs.frame_written_at(s.time_s))
    outputs.write_frames(s, so_far);  // the final state
  report_progress(report.progress, fmt::format("simulated {:.2f} s in {} steps", s.time_s, s.steps),
                  1.0);
  if (loop.stopped)
    log::info(
        "stopped after {} steps as asked (--stop-after); continue with: lamina run "
        "--resume {} -o {}",
        a.stop_after_steps, checkpoint_path, a.output);
  else if (!loop.converged && loop.unstable == sim::Instability::kNone)
    log::warn("{}: not at rest after solver.max_steps = {} steps ({:.2f} s simulated)",
              scene.source, scene.solver.max_steps, s.time_s);

  // 4. Results.
  outputs.write_results(so_far);
  io::RunSummary sum = summarize_run(ready, s, loop, so_far, cutting,
                                     {.model_s = model_seconds, .prepare_s = prepare_seconds});
  summarize_timing(loop, a, sum);
  sum.wall_seconds = seconds_since(t_start);
  const std::string json = io::run_summary_json(sum);
  write_file_atomically((outputs.out / "summary.json").string(),
                        [&](std::ostream& f) { f << json << "\n"; });

  if (loop.unstable != sim::Instability::kNone)
    throw unstable_error(scene, s, loop.unstable, a.output);
  if (a.json)
    std::cout << json << "\n";
  else
    print_run(sum, a.output, outputs.series, so_far.frame);
  return 0;
}

}  // namespace lamina::cli
