// The world loop's tissue cuts (world_loop.h, cut()): each body the blade passes through is cut
// on another thread from copies of it while the world steps on (interact::prepare_cut: the
// model divided, a simulation of it made and its solver prepared, 65 ms at paper size), then
// taken in between two steps (world::take_cut: its state of that moment, its tools and what the
// world holds by its nodes carried over), as the one-organ loop takes its cuts.
#include <fmt/format.h>
#include <omp.h>

#include <algorithm>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/sim/carry_over.h"
#include "world_loop_impl.h"

namespace lamina::world {

void WorldLoop::Impl::apply_cuts() {
  const bool background = threaded && options.background_cuts;
  take_cut(/*wait=*/!background);  // one begun in the thread before a stop() is waited for
  while (!tissue_cuts.empty() && !cut_job.valid()) {
    Stroke s = std::move(tissue_cuts.front());
    tissue_cuts.erase(tissue_cuts.begin());
    begin_cut(std::move(s));
    if (!background) take_cut(/*wait=*/true);
  }
  // After the cuts asked for before it, being made or waiting: an undo may be asked for the cut
  // just asked for (the viewer's K then U).
  apply_undos();
}

// Copies of what the cut needs from every live body (its model, shared, and its state: a copy
// of a few arrays), and the cut begun on them on another thread.
void WorldLoop::Impl::begin_cut(Stroke stroke) {
  const double t0 = now_s();
  struct Source {
    BodyId id;
    uint32_t topology;
    uint64_t parameters;
    std::string name;
    std::shared_ptr<const Model> model;
    sim::CarrySource from;
  };
  std::vector<Source> sources;
  for (const BodyId id : body_ids(world)) {
    const Body& b = body(world, id);
    sources.push_back({id, b.topology, parameters[static_cast<size_t>(id.index)], b.name, b.model,
                       sim::carry_source(b.sim)});
  }
  const bool background = threaded && options.background_cuts;
  cut_job = std::async(
      std::launch::async, [sources = std::move(sources), stroke = std::move(stroke), r = resets,
                           steps = world.steps, began = now_s(), background]() mutable {
        if (background) omp_set_num_threads(1);  // the stepping thread keeps the other core
        CutJob j{.stroke = std::move(stroke), .resets = r, .began_s = began, .steps = steps};
        for (Source& src : sources) {
          try {
            interact::PreparedCut p = interact::prepare_cut(*src.model, src.from, j.stroke.path,
                                                            j.stroke.direction, j.stroke.depth_mm);
            if (p.cut) j.bodies.push_back({src.id, src.topology, src.parameters, std::move(p)});
          } catch (const Error& e) {  // a body without tetrahedra: named, the others cut
            j.skipped += (j.skipped.empty() ? "" : "; ") + src.name + ": " + e.what();
          }
        }
        return j;
      });
  if (background) {  // the steps meanwhile: one thread fewer, the job has its core
    stepping_threads = omp_get_max_threads();
    if (stepping_threads > 1 && omp_get_num_procs() <= stepping_threads)
      omp_set_num_threads(stepping_threads - 1);
  }
  cut_begin_ms = 1e3 * (now_s() - t0);
}

// The cut made, taken in between two steps: each body it divides (unless a reset or another
// change of that body came first), kept as it was for a reset, then the ties the blade passes
// divided.
void WorldLoop::Impl::take_cut(bool wait) {
  if (!cut_job.valid()) return;
  if (!wait && cut_job.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;
  const double t0 = now_s();
  CutJob j = cut_job.get();
  if (stepping_threads > 0) omp_set_num_threads(stepping_threads);
  stepping_threads = 0;
  if (j.resets != resets) {
    log::info("world: a cut begun before the reset is dropped");
    return;
  }
  int32_t divided = 0;
  CutUndo entry;  // each body it divides as it was, and the ties then
  std::vector<std::pair<std::string, model::CutReport>> reports;
  for (CutJob::OnBody& o : j.bodies) {
    if (!is_valid(world, o.id) || body(world, o.id).topology != o.topology) {
      log::warn("world: cut: body {} changed while the cut was made; it is not cut", o.id.index);
      continue;
    }
    model::CutReport r;
    std::vector<int32_t> origin;
    try {  // kept as it was for an undo (and a reset)
      r = world::take_cut(world, o.id, o.cut, &origin, &entry.before,
                          parameters[static_cast<size_t>(o.id.index)] != o.parameters);
    } catch (const Error& e) {  // nothing of the body changed
      log::warn("world: cut: {}", e.what());
      continue;
    }
    tets_cut += r.cut_tets;
    entry.tets += r.cut_tets;
    ++divided;
    log::info("world: cut '{}': {} tetrahedra divided, {} nodes added", body(world, o.id).name,
              r.cut_tets, r.new_nodes);
    for (const model::StructureCut& x : r.structures_cut)
      log::warn("cut: {} cut across at ({:.1f}, {:.1f}, {:.1f}) mm, {:.1f} mm wide", x.name,
                x.position_mm.x(), x.position_mm.y(), x.position_mm.z(), x.diameter_mm);
    reports.emplace_back(body(world, o.id).name, std::move(r));
    std::lock_guard lock(mutex);
    topology_changed(o.id.index, &origin);
  }
  const Stroke& s = j.stroke;
  // The ties this stroke divides, for its undo (a stroke that cut no tissue has none).
  std::vector<std::vector<uint8_t>> was_divided;
  if (divided > 0) was_divided = divided_flags(world);
  strokes_divided += dissect_along(world, s.path, s.direction, s.depth_mm, s.reach_mm);
  cuts += divided;
  if (divided > 0) {
    entry.stroke_divided = divided_since(world, was_divided);
    push_cut(history, std::move(entry));
    last_cut = std::move(reports);
    ++cut_events;
  }
  last_cut_ms = cut_begin_ms + 1e3 * (now_s() - t0);  // the copies, and taking it in
  longest_cut_ms = std::max(longest_cut_ms, last_cut_ms);
  last_cut_made_ms = 1e3 * (now_s() - j.began_s);
  last_cut_steps_meanwhile = world.steps - j.steps;
  cut_message = divided > 0          ? std::string()
                : !j.skipped.empty() ? j.skipped
                                     : "the blade passed through no body's tissue";
  publish(true);
}

// Undos asked, each the newest cut taken back (world_loop.h, undo_cut()): the bodies it divided
// put back as they were just before it, on the clock of now and with the parameters set since.
void WorldLoop::Impl::apply_undos() {
  if (undos == 0 || cut_job.valid() || !tissue_cuts.empty()) return;
  for (; undos > 0; --undos) {
    if (history.undo.empty()) {
      cut_message = "undo: there is no cut to undo";
      log::warn("world: {}", cut_message);
      undos = 0;
      break;
    }
    CutUndo u = std::move(history.undo.back());
    history.undo.pop_back();
    // Each body it divided; the live forces on it go back to the nodes their copies came from.
    std::vector<int32_t> slots;
    std::vector<std::vector<interact::LiveForce>> back;
    for (const BodyBefore& k : u.before.bodies) {
      slots.push_back(k.id.index);
      if (k.id.index == grasp_slot) open_grasper();  // its nodes are renumbered under the jaws
      std::vector<interact::LiveForce>& f = back.emplace_back();
      for (const interact::LiveForce& x : live[static_cast<size_t>(k.id.index)].forces)
        if (x.node >= 0 && static_cast<size_t>(x.node) < k.origin.size())
          f.push_back({k.origin[static_cast<size_t>(x.node)], x.force_mn, x.radius_mm});
    }
    const int64_t tets = u.tets;
    strokes_divided -= world::undo_cut(world, u);
    for (size_t k = 0; k < slots.size(); ++k) {
      std::lock_guard lock(mutex);
      topology_changed(slots[k]);
      live[static_cast<size_t>(slots[k])].forces = std::move(back[k]);
      route_forces(slots[k]);
    }
    follow_the_clock();                          // the rate may have changed since
    cuts -= static_cast<int32_t>(slots.size());  // one per body it divided
    tets_cut -= tets;
    cut_message.clear();
    last_cut.clear();
    ++cut_events;
    log::info("world: undo: the last cut taken back ({} cut(s) in force)", cuts);
  }
  publish(true);
}

}  // namespace lamina::world
