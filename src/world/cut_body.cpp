// A body of a world cut, and everything the world holds by its node numbers renumbered with it:
// the one place where a body's topology changes (a cut, and a reset putting the uncut body back).
#include "lamina/world/cut_body.h"

#include <algorithm>
#include <utility>

#include "lamina/core/error.h"
#include "lamina/interact/scalpel.h"
#include "lamina/world/dissection.h"
#include "world_work.h"

namespace lamina::world {

// Copies are numbered in their node's order, so the first copy of node v is the first new node
// whose origin is v.
std::vector<int32_t> first_copies(const std::vector<int32_t>& origin, int32_t old_nodes) {
  std::vector<int32_t> first(static_cast<size_t>(old_nodes), -1);
  for (size_t i = origin.size(); i-- > 0;)
    first[static_cast<size_t>(origin[i])] = static_cast<int32_t>(i);
  return first;
}

namespace {

// What the step caches of a body's skin is not the renumbered body's: its grid, every pair's
// clearances and near lists (keyed by the models' addresses, which a new model may reuse), its
// nodes' areas. All are made again on the next step.
void forget_skin(World& world, size_t slot) {
  detail::WorldWork& w = world.work();
  if (slot < w.grids.size()) w.grids[slot] = detail::SkinGrid{};
  if (slot < w.node_area.size()) w.node_area[slot].clear();
  w.clearance.clear();
  w.near.clear();
}

// A body renumbered from `before`'s nodes to `after`'s (per new node, the old one it came
// from): the ties on its nodes and on its skin, its rest overlaps and its contacts' memory.
void renumber(World& world, int32_t slot, int32_t before_nodes,
              const std::vector<int32_t>& origin) {
  const std::vector<int32_t> first = first_copies(origin, before_nodes);
  Body& b = world.bodies[static_cast<size_t>(slot)].body;
  // A tie holds the node's first copy (the copies of a skin node lie where it was; a tool by
  // vertex takes the same one: interact::carry_tools), and the point of the skin it was tied to
  // on the first copies of its triangle's corners, with the same weights.
  for (AttachmentSlot& a : world.attachments) {
    if (!a.alive) continue;
    for (Tie& t : a.attachment.ties) {
      if (t.node_body == slot) t.node = first[static_cast<size_t>(t.node)];
      if (t.surface_body == slot)
        for (int32_t& c : t.corners) c = first[static_cast<size_t>(c)];
    }
  }
  std::vector<double> overlap(origin.size(), 0.0);
  if (b.rest_overlap_mm.size() == static_cast<size_t>(before_nodes))
    for (size_t i = 0; i < origin.size(); ++i)
      overlap[i] = b.rest_overlap_mm[static_cast<size_t>(origin[i])];
  b.rest_overlap_mm = std::move(overlap);
  detail::WorldWork& w = world.work();
  if (static_cast<size_t>(slot) < w.pushed.size()) {
    std::vector<uint8_t>& p = w.pushed[static_cast<size_t>(slot)];
    std::vector<uint8_t> moved(origin.size(), 0);
    if (p.size() == static_cast<size_t>(before_nodes))
      for (size_t i = 0; i < origin.size(); ++i) moved[i] = p[static_cast<size_t>(origin[i])];
    p = std::move(moved);
  }
  forget_skin(world, static_cast<size_t>(slot));
  ++b.topology;
}

bool kept(const WorldBefore& before, BodyId id) {
  return std::any_of(before.bodies.begin(), before.bodies.end(),
                     [&](const BodyBefore& k) { return k.id == id; });
}

// The ties as they are, the first time anything is kept.
void keep_ties(const World& world, WorldBefore& before) {
  if (!before.ties.empty()) return;
  before.ties.resize(world.attachments.size());
  for (size_t a = 0; a < world.attachments.size(); ++a)
    if (world.attachments[a].alive) before.ties[a] = world.attachments[a].attachment.ties;
}

}  // namespace

std::vector<interact::CutEvent> advance_scalpels(World& world, BodyId id,
                                                 interact::ScalpelDriver& scalpels) {
  Body& b = body(world, id);
  const int32_t before_nodes = b.model->node_count();
  std::shared_ptr<const Model> model = b.model;
  std::vector<int32_t> origin;
  std::vector<interact::CutEvent> events =
      interact::advance_scalpels(scalpels, model, b.sim, b.tools, &origin);
  if (model != b.model) {
    // The cut model is cut_simulation()'s own, held by nobody else: the body's to hold.
    b.model = model;
    renumber(world, id.index, before_nodes, origin);
  }
  return events;
}

model::CutReport cut_body(World& world, BodyId id, const std::vector<Eigen::Vector3d>& path,
                          const Eigen::Vector3d& direction, double depth_mm,
                          std::vector<int32_t>* origin) {
  Body& b = body(world, id);
  interact::PreparedCut prepared =
      interact::prepare_cut(*b.model, sim::carry_source(b.sim), path, direction, depth_mm);
  return take_cut(world, id, prepared, origin);
}

model::CutReport take_cut(World& world, BodyId id, interact::PreparedCut& prepared,
                          std::vector<int32_t>* origin, WorldBefore* before,
                          bool parameters_changed) {
  Body& b = body(world, id);
  const int32_t before_nodes = b.model->node_count();
  if (!prepared.cut) {
    if (origin != nullptr) {
      origin->resize(static_cast<size_t>(before_nodes));
      for (size_t i = 0; i < origin->size(); ++i) (*origin)[i] = static_cast<int32_t>(i);
    }
    return std::move(prepared.report);
  }
  if (prepared.sim->model().node_count() != static_cast<int32_t>(prepared.origin.size()) ||
      std::any_of(prepared.origin.begin(), prepared.origin.end(),
                  [&](int32_t o) { return o < 0 || o >= before_nodes; }))
    throw invalid_input("cut of body '" + b.name + "'",
                        "the prepared cut is of another model than the body's");
  std::vector<int32_t> from = prepared.origin;
  // A rate changed since the cut was prepared changed the body's dt.
  std::shared_ptr<const Model> model = b.model;
  const bool changed = parameters_changed || prepared.sim->options().dt_s != b.sim.options().dt_s;
  // Kept for a reset as keep_before() keeps it, but the simulation replaced is moved there, not
  // copied (a copy of the paper-size liver's took about 2 ms of the stepping thread's pause).
  const bool keep = before != nullptr && !kept(*before, id);
  if (keep) keep_ties(world, *before);
  interact::ToolDriver tools_before = keep ? b.tools : interact::ToolDriver{};
  std::optional<sim::Simulation> was = interact::take_cut(model, b.sim, b.tools, prepared, changed);
  if (keep)
    before->bodies.push_back({.id = id,
                              .model = b.model,
                              .sim = std::move(*was),
                              .tools = std::move(tools_before),
                              .rest_overlap_mm = b.rest_overlap_mm,
                              .origin = from});
  model::CutReport report = std::move(prepared.report);
  b.model = model;
  renumber(world, id.index, before_nodes, from);
  if (origin != nullptr) *origin = std::move(from);
  return report;
}

model::CutReport cut_body(World& world, BodyId id, const std::vector<Eigen::Vector3d>& path,
                          const Eigen::Vector3d& direction, double depth_mm, WorldBefore& before) {
  interact::PreparedCut prepared = interact::prepare_cut(
      *body(world, id).model, sim::carry_source(body(world, id).sim), path, direction, depth_mm);
  return take_cut(world, id, prepared, nullptr, &before);
}

WorldCut cut_through(World& world, const std::vector<Eigen::Vector3d>& path,
                     const Eigen::Vector3d& direction, double depth_mm, double reach_mm,
                     WorldBefore& before) {
  check_stroke("cut", path, direction, depth_mm, reach_mm);
  WorldCut out;
  for (const BodyId id : body_ids(world)) {
    try {
      model::CutReport r = cut_body(world, id, path, direction, depth_mm, before);
      if (r.cut_tets > 0) out.bodies.emplace_back(id, std::move(r));
    } catch (const Error& e) {  // a body without tetrahedra: named, the others cut
      out.skipped += (out.skipped.empty() ? "" : "; ") + body(world, id).name + ": " + e.what();
    }
  }
  out.ties_divided = dissect_along(world, path, direction, depth_mm, reach_mm);
  return out;
}

void keep_before(const World& world, BodyId id, WorldBefore& before) {
  const Body& b = body(world, id);
  keep_ties(world, before);
  if (kept(before, id)) return;
  before.bodies.push_back({.id = id,
                           .model = b.model,
                           .sim = b.sim,
                           .tools = b.tools,
                           .rest_overlap_mm = b.rest_overlap_mm});
}

void put_back(World& world, WorldBefore& before) {
  for (BodyBefore& k : before.bodies) {
    if (!is_valid(world, k.id)) continue;  // destroyed since: nothing to put back
    Body& b = body(world, k.id);
    b.model = std::move(k.model);
    b.sim = std::move(k.sim);
    b.tools = std::move(k.tools);
    b.rest_overlap_mm = std::move(k.rest_overlap_mm);
    detail::WorldWork& w = world.work();
    if (static_cast<size_t>(k.id.index) < w.pushed.size())
      w.pushed[static_cast<size_t>(k.id.index)].assign(static_cast<size_t>(b.model->node_count()),
                                                       0);
    forget_skin(world, static_cast<size_t>(k.id.index));
    ++b.topology;
  }
  for (size_t a = 0; a < before.ties.size() && a < world.attachments.size(); ++a)
    if (world.attachments[a].alive && !before.ties[a].empty())
      world.attachments[a].attachment.ties = std::move(before.ties[a]);
  before = WorldBefore{};
}

void fold_before(WorldBefore& earlier, WorldBefore& later) {
  for (BodyBefore& k : later.bodies)
    if (!kept(earlier, k.id)) earlier.bodies.push_back(std::move(k));
  if (earlier.ties.empty()) earlier.ties = std::move(later.ties);
  later = WorldBefore{};
}

}  // namespace lamina::world
