// `lamina run` on a world scene (io::WorldScene, docs/scenes.md "World scenes"): every body
// stepped in one world (world::step: tools, contact and attachments, each body's solve), the
// dissections dividing the ties they pass and each body's scalpels cutting it, until every tool
// and blade is done and every body has rested. Writes a VTK series per body's skin and structure,
// metrics.csv (the world's stages and each body's measures per step) and summary.json (bodies,
// attachments, timing).
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <limits>
#include <nlohmann/json.hpp>
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
#include "lamina/io/mesh_file.h"
#include "lamina/io/world_scene.h"
#include "lamina/model/embed_surface.h"
#include "lamina/model/structure_colors.h"
#include "lamina/model/summarize_model.h"
#include "series_files.h"
#include "world_run_summary.h"
#include "world_scalpels.h"

namespace lamina::cli {
namespace {

namespace fs = std::filesystem;

// A surface of one body written at every frame: its skin or an embedded structure.
struct BodySeries {
  std::string name;       // "liver_skin", "liver_portal_vein"
  size_t body = 0;        // index into the ready world's bodies
  int32_t embedded = -1;  // -1: the skin (layer 0)
  SurfaceMesh mesh;
  model::Rgb8 color = model::kOrganColor;
  std::vector<std::pair<double, std::string>> files;
};

// Body b's embedded surfaces the scene writes (output.embedded; the display skin with
// output.display_skin) that have no series yet, each as its own, named after both
// ("liver_portal_vein"; after a cut, "liver_wound").
void add_body_series(std::vector<BodySeries>& series, const world::Body& body, size_t b,
                     const io::SceneOutput& output, std::set<std::string>& names) {
  if (!output.embedded) return;
  const Model& m = *body.model;
  const std::vector<model::Rgb8> colors = model::structure_colors(m);
  for (size_t k = 0; k < m.embedded.size(); ++k) {
    const bool display = static_cast<int32_t>(k) == model::display_skin_index(m);
    const bool has = std::any_of(series.begin(), series.end(), [&](const BodySeries& se) {
      return se.body == b && se.embedded == static_cast<int32_t>(k);
    });
    if (has || !(display ? output.display_skin : output.embedded)) continue;
    BodySeries& se = series.emplace_back();
    se.name = series_name(body.name + "_" + m.embedded[k].name, names);
    se.body = b;
    se.embedded = static_cast<int32_t>(k);
    se.mesh.F = m.embedded[k].F;
    se.color = colors[k];
    names.insert(se.name);
  }
}

std::vector<BodySeries> world_series(const io::ReadyWorld& w, const io::SceneOutput& output) {
  std::vector<BodySeries> out;
  std::set<std::string> names;
  for (size_t b = 0; b < w.ids.size(); ++b) {
    const world::Body& body = world::body(w.world, w.ids[b]);
    BodySeries& skin = out.emplace_back();
    skin.name = series_name(body.name + "_skin", names);
    skin.body = b;
    skin.mesh = model::layer_mesh(*body.model, 0);
    names.insert(skin.name);
    add_body_series(out, body, b, output, names);
  }
  return out;
}

void write_world_frame(std::vector<BodySeries>& series, const io::ReadyWorld& w,
                       const fs::path& out, int32_t index, bool obj) {
  for (BodySeries& se : series) {
    const sim::Simulation& s = world::body(w.world, w.ids[se.body]).sim;
    if (se.embedded >= 0) {
      model::embedded_positions(s.model().embedded[static_cast<size_t>(se.embedded)], s.x,
                                se.mesh.V);
    } else {
      const ModelLayer& skin = s.model().layers[0];
      se.mesh.V = s.x.middleRows(skin.first_node, skin.node_count);
    }
    const std::string stem = fmt::format("frames/{}_{:06d}", se.name, index);
    io::write_mesh(se.mesh, (out / (stem + ".vtp")).string(), se.color);
    if (obj) io::write_mesh(se.mesh, (out / (stem + ".obj")).string());
    se.files.emplace_back(w.world.time_s, stem + ".vtp");
  }
}

// A body cut: its series' triangles are the cut model's, and a surface the cut added (the wound)
// gets a series of its own when the scene writes the embedded surfaces.
void follow_cut(std::vector<BodySeries>& series, const io::ReadyWorld& w, size_t b,
                const io::SceneOutput& output) {
  const world::Body& body = world::body(w.world, w.ids[b]);
  const Model& m = *body.model;
  std::set<std::string> names;
  for (BodySeries& se : series) {
    names.insert(se.name);
    if (se.body != b) continue;
    se.mesh.F = se.embedded < 0 ? model::layer_mesh(m, 0).F
                                : m.embedded[static_cast<size_t>(se.embedded)].F;
  }
  add_body_series(series, body, b, output, names);
}

// The active ties at this frame as lines (frames/ties_NNNNNN.vtp, their pull in mN), listed in
// ties.pvd: the attachments drawn beside the organs.
void write_ties_frame(const world::World& w, const fs::path& out, int32_t index,
                      std::vector<std::pair<double, std::string>>& files) {
  std::vector<const world::Tie*> active;
  for (const world::AttachmentSlot& slot : w.attachments)
    if (slot.alive)
      for (const world::Tie& t : slot.attachment.ties)
        if (t.active()) active.push_back(&t);
  const auto n = static_cast<Eigen::Index>(active.size());
  Eigen::MatrixX3d from(n, 3), to(n, 3);
  std::vector<double> pull(active.size());
  for (Eigen::Index k = 0; k < n; ++k) {
    const auto [p, q] = world::tie_ends(w, *active[static_cast<size_t>(k)]);
    from.row(k) = p.transpose();
    to.row(k) = q.transpose();
    pull[static_cast<size_t>(k)] = active[static_cast<size_t>(k)]->force_mn;
  }
  const std::string stem = fmt::format("frames/ties_{:06d}.vtp", index);
  io::write_segments_vtp(from, to, pull, "pull_mn", (out / stem).string());
  files.emplace_back(w.time_s, stem);
}

std::string metrics_header(const io::ReadyWorld& w) {
  std::string h = "time_s,step_us,tools_us,contact_us,solve_us,ties_active,ties_divided,ties_torn";
  for (const world::BodyId id : w.ids) {
    const std::string& n = world::body(w.world, id).name;
    for (const char* col : {"max_displacement_mm", "volume_change_pct", "penetration_mm",
                            "contacts", "contact_force_mn", "attachment_force_mn", "converged"})
      h += fmt::format(",{}_{}", n, col);
  }
  return h + "\n";
}

void append_metrics(std::string& csv, const world::World& w, const world::WorldStepStats& st) {
  const world::TieCount ties = world::count_ties(w);
  fmt::format_to(std::back_inserter(csv), "{:.10g},{:.2f},{:.2f},{:.2f},{:.2f},{},{},{}", w.time_s,
                 st.step_us, st.profile.tools_us, st.profile.contact_us, st.profile.solve_us,
                 ties.total - ties.divided - ties.torn, ties.divided, ties.torn);
  for (const world::BodyStepStats& b : st.bodies)
    fmt::format_to(std::back_inserter(csv), ",{:.9g},{:.9g},{:.6g},{},{:.6g},{:.6g},{}",
                   b.sim.max_displacement_mm, b.sim.volume_change_pct, b.max_penetration_mm,
                   b.contacts + b.self_contacts, b.contact_force_mn.norm(),
                   b.attachment_force_mn.norm(), b.sim.converged ? 1 : 0);
  csv += '\n';
}

// Seconds after which the world is watched for rest: every finite tool's end and every blade's.
double settle_from_s(const io::ReadyWorld& w, const io::WorldScene& scene,
                     const std::vector<BodyScalpels>& scalpels) {
  double t = scalpels_end_s(scalpels);
  for (const world::BodyId id : w.ids)
    for (const interact::Tool& tool : world::body(w.world, id).tools.tools)
      t = std::max(t, std::isfinite(tool.end_s) ? tool.end_s : tool.start_s);
  for (const world::Dissection& d : scene.dissections) t = std::max(t, d.blade.end_s);
  return t;
}

WorldRunRecord step_world(const RunArgs& a, const io::WorldScene& scene, io::ReadyWorld& w,
                          std::vector<BodyScalpels>& scalpels, std::vector<BodySeries>& series,
                          const fs::path& out, std::string& csv, const ProgressFn& progress) {
  WorldRunRecord loop;
  loop.bodies.resize(w.ids.size());
  const double settle = settle_from_s(w, scene, scalpels);
  std::vector<interact::RestWatch> rest;
  for (const world::BodyId id : w.ids) {
    const world::Body& b = world::body(w.world, id);
    interact::RestWatch r = interact::rest_watch(b.sim, b.tools);
    r.settle_from_s = std::max(r.settle_from_s, settle);
    rest.push_back(r);
  }
  const double interval = scene.output.frame_interval_s;
  double next_frame = interval;
  const auto frame = [&] {
    if (!w.attachments.empty()) write_ties_frame(w.world, out, loop.frames, loop.tie_files);
    write_world_frame(series, w, out, loop.frames++, scene.output.obj);
  };
  frame();
  interact::Pacer pacer(a.realtime ? a.rate_hz : 0.0);
  pacer.restart();
  const auto start = Clock::now();
  auto last_report = Clock::now();
  world::WorldStepStats st;
  loop.step_us.reserve(static_cast<size_t>(std::min<int64_t>(scene.solver.max_steps, 1 << 20)));
  for (int64_t k = 0; k < scene.solver.max_steps; ++k) {
    const double t0 = w.world.time_s;
    const auto c0 = Clock::now();
    for (const size_t b : advance_world_scalpels(w, scalpels))
      follow_cut(series, w, b, scene.output);
    const int32_t divided =
        world::advance_dissections(scene.dissections, w.world, t0, t0 + scene.solver.dt_s);
    world::step(w.world, st);
    const double us = std::chrono::duration<double, std::micro>(Clock::now() - c0).count();
    loop.step_us.push_back(us);
    loop.total_us += st.step_us;
    loop.contact_us += st.profile.contact_us;
    if (divided > 0) log::debug("t = {:.3f} s: a dissection divided {} ties", t0, divided);
    if (st.ties_torn > 0) log::debug("t = {:.3f} s: {} ties tore", t0, st.ties_torn);
    bool all_rest = true;
    for (size_t b = 0; b < st.bodies.size(); ++b) {
      const world::BodyStepStats& bs = st.bodies[b];
      BodyRecord& r = loop.bodies[b];
      r.last = bs.sim;
      r.max_penetration_mm = std::max(r.max_penetration_mm, bs.max_penetration_mm);
      r.max_displacement_mm = std::max(r.max_displacement_mm, bs.sim.max_displacement_mm);
      r.max_abs_volume_change_pct =
          std::max(r.max_abs_volume_change_pct, std::abs(bs.sim.volume_change_pct));
      r.max_contact_force_mn = std::max(r.max_contact_force_mn, bs.contact_force_mn.norm());
      // Every step (a pass over the tetrahedra, a fraction of the solve's): an element
      // inverted between two frames is still found.
      const world::Body& body = world::body(w.world, w.ids[b]);
      r.max_inverted_tets =
          std::max(r.max_inverted_tets, sim::inverted_tets(*body.model, body.sim.x));
      all_rest = rest[b].update(t0, bs.sim) && all_rest;
    }
    loop.converged = all_rest && st.ties_torn == 0;
    const bool frame_due = interval > 0.0 && w.world.time_s >= next_frame - 1e-9 * interval;
    if (frame_due) {
      frame();
      while (next_frame <= w.world.time_s + 1e-9 * interval) next_frame += interval;
    }
    if (scene.output.metrics_every_step || frame_due || loop.converged)
      append_metrics(csv, w.world, st);
    if (st.unstable != sim::Instability::kNone) {
      loop.unstable = st.unstable;
      loop.unstable_body = st.unstable_body;
      break;
    }
    if (loop.converged) break;
    if (progress && seconds_since(last_report) >= (::isatty(2) ? 0.1 : 2.0)) {
      last_report = Clock::now();
      const double fraction = settle > 0.0 ? std::min(0.99, 0.9 * w.world.time_s / settle) : 0.5;
      report_progress(
          progress,
          fmt::format("simulating the world: t = {:.2f} s, step {}, {} ties divided",
                      w.world.time_s, w.world.steps, world::count_ties(w.world).divided),
          fraction);
    }
    if (a.realtime) std::this_thread::sleep_until(pacer.advance());
  }
  loop.wall_s = seconds_since(start);
  if (series.front().files.back().first != w.world.time_s) frame();  // the final state
  return loop;
}

}  // namespace

int run_world(const RunArgs& a) {
  const auto t_start = Clock::now();
  if (a.paper)
    throw invalid_input("--paper", "cannot be given with a world scene (" + a.scene + ")");
  if (!a.resume.empty() || a.checkpoint_every > 0 || a.stop_after_steps > 0)
    throw invalid_input(a.scene,
                        "a world scene cannot be checkpointed or resumed yet (run it "
                        "without --checkpoint-every, --stop-after and --resume)");
  if (a.realtime && !(a.rate_hz > 0.0 && a.rate_hz <= 1e6))
    throw invalid_input("--rate", "must be in (0, 1e6] steps per second");
  io::WorldScene scene = io::load_world_scene(a.scene);
  if (a.realtime && scene.solver.dt_s != 1.0 / a.rate_hz) {
    log::info("{}: --realtime at {:g} Hz steps dt = {:g} s (the scene says {:g} s)", scene.source,
              a.rate_hz, 1.0 / a.rate_hz, scene.solver.dt_s);
    scene.solver.dt_s = 1.0 / a.rate_hz;
    for (io::WorldBodyScene& b : scene.bodies) b.scene.solver.dt_s = scene.solver.dt_s;
  }
  check_output_folder(a.output);
  const ProgressFn progress = a.quiet ? ProgressFn{} : stderr_progress(a.verbose);
  const std::unique_ptr<io::ReadyWorld> w =
      io::make_ready_world(scene, volume_read_options, progress, /*scalpels_cut=*/true);
  std::vector<BodyScalpels> scalpels = world_scalpels(*w, scene.source);
  // A cut makes its body's model and simulation again: their memory reused, not faulted in
  // afresh at every event (as in the real-time loops).
  for (const BodyScalpels& b : scalpels)
    if (!b.driver.scalpels.empty()) keep_freed_memory();
  const double model_s = seconds_since(t_start);
  const fs::path out(a.output);
  create_folder(out / "frames");
  std::vector<BodySeries> series = world_series(*w, scene.output);
  std::set<std::string> names;
  for (const BodySeries& se : series) names.insert(se.name);
  names.insert("ties");
  for (size_t b = 0; b < scalpels.size(); ++b)  // a cut adds its wound's series as it goes
    if (!scalpels[b].driver.scalpels.empty())
      names.insert(
          series_name(world::body(w->world, w->ids[b]).name + "_" + model::kWoundName, {}));
  remove_stale_frames(out / "frames", names, 0);

  std::string csv = metrics_header(*w);
  const WorldRunRecord loop = step_world(a, scene, *w, scalpels, series, out, csv, progress);
  report_progress(progress,
                  fmt::format("simulated {:.2f} s in {} steps", w->world.time_s, w->world.steps),
                  1.0);
  if (!loop.converged && loop.unstable == sim::Instability::kNone)
    log::warn("{}: not at rest after solver.max_steps = {} steps ({:.2f} s simulated)",
              scene.source, scene.solver.max_steps, w->world.time_s);
  write_file_atomically((out / "metrics.csv").string(), [&](std::ostream& f) { f << csv; });
  for (const BodySeries& se : series) write_pvd(out, se.name, se.files);
  if (!loop.tie_files.empty()) write_pvd(out, "ties", loop.tie_files);
  const nlohmann::json sum =
      world_summary_json(scene, *w, loop, scalpels, model_s, seconds_since(t_start), a);
  write_file_atomically((out / "summary.json").string(),
                        [&](std::ostream& f) { f << sum.dump(2) << "\n"; });
  if (loop.unstable != sim::Instability::kNone)
    throw Error(
        ErrorKind::kUnstable,
        fmt::format("{}: body '{}' unstable at t = {:.3g} s: {}; a tool force, dt = {:g} s, "
                    "the contact or the attachments' stiffness is beyond what it can "
                    "take: lower it (the run until then is in {})",
                    scene.source, loop.unstable_body, w->world.time_s, sim::describe(loop.unstable),
                    scene.solver.dt_s, a.output));
  if (a.json) {
    std::cout << sum.dump() << "\n";
    return 0;
  }
  print_world_summary(scene, *w, loop, scalpels, sum, seconds_since(t_start), a.output,
                      series.size());
  return 0;
}

}  // namespace lamina::cli
