// The world's bodies and attachments behind handles that say when they are stale: creating,
// destroying, finding; each body's rest overlap with the others measured as it joins.
#include "lamina/world/world.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "lamina/core/error.h"
#include "lamina/geometry/closest_on_triangle.h"
#include "lamina/geometry/winding_number.h"
#include "lamina/model/summarize_model.h"
#include "world_work.h"

namespace lamina::world {

World::World() : work_(std::make_unique<detail::WorldWork>()) {}
World::~World() = default;
World::World(World&&) noexcept = default;
World& World::operator=(World&&) noexcept = default;

namespace {

Error refused(const std::string& what) {
  return Error(ErrorKind::kInvalidInput, what);
}

std::string handle_text(int32_t index, uint32_t generation) {
  return std::to_string(index) + "." + std::to_string(generation);
}

double world_dt(const World& world) {
  for (const BodySlot& s : world.bodies)
    if (s.alive) return s.body.sim.options().dt_s;
  return 0.0;
}

// Each node's deepest rest overlap (into another body, or behind its own far side). Throws,
// naming both bodies, when two bodies overlap beyond the tolerance.
void measure_rest_overlaps(World& world) {
  for (BodySlot& s : world.bodies)
    if (s.alive)
      s.body.rest_overlap_mm.assign(static_cast<size_t>(s.body.model->node_count()), 0.0);
  detail::find_contacts(world, /*measure_rest=*/true);
  const detail::WorldWork& w = world.work();
  const Contact* worst = nullptr;
  for (const Contact& c : w.contacts) {
    std::vector<double>& o = world.bodies[static_cast<size_t>(c.body)].body.rest_overlap_mm;
    o[static_cast<size_t>(c.node)] = std::max(o[static_cast<size_t>(c.node)], c.depth_mm);
    if (c.body != c.other && (worst == nullptr || c.depth_mm > worst->depth_mm)) worst = &c;
  }
  if (worst != nullptr && worst->depth_mm > world.contact.rest_overlap_tolerance_mm) {
    const Body& a = world.bodies[static_cast<size_t>(worst->body)].body;
    const Body& b = world.bodies[static_cast<size_t>(worst->other)].body;
    const Eigen::Vector3d p = a.model->X.row(worst->node);
    throw refused(fmt::format(
        "bodies '{}' and '{}' overlap by {:.1f} mm at rest (a node of '{}' at ({:.1f}, {:.1f}, "
        "{:.1f}) mm lies inside '{}'), more than contact.rest_overlap_tolerance_mm = {:g}: place "
        "them apart, or resolve the overlap in the segmentation",
        a.name, b.name, worst->depth_mm, a.name, p.x(), p.y(), p.z(), b.name,
        world.contact.rest_overlap_tolerance_mm));
  }
}

// How deep the deepest of a sample of `a`'s interior nodes lies inside `b`'s skin at rest, and
// where. A body inside another, or two in one place, meets no skin within the contact's reach,
// so the contact search sees no overlap there: its inner nodes are tested instead (winding
// number, then the distance to the skin), at most about 400 of them.
std::pair<double, Eigen::Vector3d> deepest_inside(const Model& a, const Model& b) {
  const SurfaceMesh skin = model::layer_mesh(b, 0);
  const Eigen::Vector3d lo = skin.V.colwise().minCoeff(), hi = skin.V.colwise().maxCoeff();
  const int32_t first = a.layers[0].node_count, n = a.node_count();
  const int32_t stride = std::max<int32_t>(1, (n - first) / 400);
  std::pair<double, Eigen::Vector3d> deepest{0.0, Eigen::Vector3d::Zero()};
  for (int32_t i = first; i < n; i += stride) {
    const Eigen::Vector3d p = a.X.row(i);
    if ((p.array() < lo.array()).any() || (p.array() > hi.array()).any()) continue;
    if (geometry::winding_number(skin.V, skin.F, p) < 0.5) continue;
    double d = std::numeric_limits<double>::infinity();
    for (Eigen::Index f = 0; f < skin.F.rows(); ++f) {
      const Eigen::Vector3d u = skin.V.row(skin.F(f, 0)), v = skin.V.row(skin.F(f, 1)),
                            w = skin.V.row(skin.F(f, 2));
      const Eigen::Vector3d c = geometry::closest_on_triangle(p, u, v, w);
      d = std::min(d, (p - (c.x() * u + c.y() * v + c.z() * w)).norm());
    }
    if (d > deepest.first) deepest = {d, p};
  }
  return deepest;
}

// Refuses `def` if one of its inner nodes lies inside a body of the world, or one of theirs
// inside it, deeper than the tolerance.
void refuse_deep_overlap(const World& world, const BodyDef& def) {
  for (const BodySlot& s : world.bodies) {
    if (!s.alive) continue;
    const Model& other = *s.body.model;
    for (const bool mine : {true, false}) {
      const auto [depth, at] =
          mine ? deepest_inside(*def.model, other) : deepest_inside(other, *def.model);
      if (depth <= world.contact.rest_overlap_tolerance_mm) continue;
      const std::string& in = mine ? def.name : s.body.name;
      const std::string& out = mine ? s.body.name : def.name;
      throw refused(fmt::format(
          "bodies '{}' and '{}' overlap by {:.1f} mm at rest (a node inside '{}' at ({:.1f}, "
          "{:.1f}, {:.1f}) mm lies inside '{}'), more than contact.rest_overlap_tolerance_mm = "
          "{:g}: place them apart, or resolve the overlap in the segmentation",
          s.body.name, def.name, depth, in, at.x(), at.y(), at.z(), out,
          world.contact.rest_overlap_tolerance_mm));
    }
  }
}

}  // namespace

BodyId create_body(World& world, BodyDef def) {
  if (!def.model) throw refused("body '" + def.name + "': no model");
  if (&def.simulation.model() != def.model.get())
    throw refused("body '" + def.name + "': its simulation was not made on its model");
  if (def.model->layers.empty() || def.model->layers.front().F.rows() == 0)
    throw refused("body '" + def.name + "': its model has no skin");
  if (def.name.empty()) throw refused("a body needs a name");
  if (find_body(world, def.name).index >= 0)
    throw refused("body '" + def.name + "': the world has a body of that name already");
  const double dt = world_dt(world);
  if (dt > 0.0 && def.simulation.options().dt_s != dt)
    throw refused(fmt::format("body '{}': its dt {:g} s differs from the world's {:g} s", def.name,
                              def.simulation.options().dt_s, dt));
  refuse_deep_overlap(world, def);
  size_t slot = 0;
  while (slot < world.bodies.size() && world.bodies[slot].alive) ++slot;
  if (slot == world.bodies.size()) world.bodies.emplace_back();
  BodySlot& s = world.bodies[slot];
  // What the step cached of the slot's last body (its skin's grid and clearances) is not this
  // one's.
  detail::WorldWork& work = world.work();
  if (slot < work.grids.size()) work.grids[slot] = detail::SkinGrid{};
  work.clearance.clear();  // made again on the next step, for every pair
  work.near.clear();
  s.body = Body{.name = std::move(def.name),
                .model = std::move(def.model),
                .sim = std::move(def.simulation),
                .tools = std::move(def.tools),
                .topology = 0,
                .rest_overlap_mm = {}};
  s.alive = true;
  try {
    measure_rest_overlaps(world);
  } catch (...) {
    s.alive = false;
    s.body = Body{};
    ++s.generation;
    for (BodySlot& o : world.bodies)  // the others' overlaps as they were
      if (o.alive) o.body.rest_overlap_mm.clear();
    if (std::any_of(world.bodies.begin(), world.bodies.end(),
                    [](const BodySlot& b) { return b.alive; })) {
      try {
        measure_rest_overlaps(world);
      } catch (...) {
      }
    }
    throw;
  }
  return {static_cast<int32_t>(slot), s.generation};
}

bool is_valid(const World& world, BodyId id) {
  return id.index >= 0 && static_cast<size_t>(id.index) < world.bodies.size() &&
         world.bodies[static_cast<size_t>(id.index)].alive &&
         world.bodies[static_cast<size_t>(id.index)].generation == id.generation;
}

const Body& body(const World& world, BodyId id) {
  if (!is_valid(world, id))
    throw refused("body handle " + handle_text(id.index, id.generation) +
                  " is stale: it names no body of this world (destroyed, or from another world)");
  return world.bodies[static_cast<size_t>(id.index)].body;
}

Body& body(World& world, BodyId id) {
  return const_cast<Body&>(body(static_cast<const World&>(world), id));
}

void destroy_body(World& world, BodyId id) {
  (void)body(world, id);
  BodySlot& s = world.bodies[static_cast<size_t>(id.index)];
  for (AttachmentSlot& a : world.attachments)
    if (a.alive && (a.attachment.body_a == id.index || a.attachment.body_b == id.index)) {
      a.alive = false;
      a.attachment = Attachment{};
      ++a.generation;
    }
  s.alive = false;
  s.body = Body{};
  ++s.generation;
}

BodyId find_body(const World& world, const std::string& name) {
  for (size_t i = 0; i < world.bodies.size(); ++i)
    if (world.bodies[i].alive && world.bodies[i].body.name == name)
      return {static_cast<int32_t>(i), world.bodies[i].generation};
  return {};
}

std::vector<BodyId> body_ids(const World& world) {
  std::vector<BodyId> ids;
  for (size_t i = 0; i < world.bodies.size(); ++i)
    if (world.bodies[i].alive) ids.push_back({static_cast<int32_t>(i), world.bodies[i].generation});
  return ids;
}

namespace {

// Ties from every skin node of `from` within reach of `to`'s skin at rest.
void tie_nodes(World& world, int32_t from, int32_t to, const AttachmentDef& def,
               std::vector<Tie>& ties) {
  const Body& fb = world.bodies[static_cast<size_t>(from)].body;
  const Body& tb = world.bodies[static_cast<size_t>(to)].body;
  detail::SkinGrid grid;
  detail::build_skin_grid(*tb.model, tb.model->X, def.reach_mm, grid);
  const std::vector<double> area = detail::skin_node_area(*fb.model);
  const ModelLayer& skin = fb.model->layers.front();
  Contact c;
  for (int32_t n = skin.first_node; n < skin.first_node + skin.node_count; ++n) {
    const Eigen::Vector3d p = fb.model->X.row(n);
    if (!detail::nearest_on_skin(*tb.model, tb.model->X, grid, p, n, false, *fb.model, 0.0,
                                 def.reach_mm, c))
      continue;
    // Ties are made from both bodies' nodes: each stands for half of its node's area.
    const double a = 0.5 * area[static_cast<size_t>(n)];
    ties.push_back({.node_body = from,
                    .surface_body = to,
                    .node = n,
                    .corners = c.corners,
                    .weights = c.weights,
                    .rest_mm = std::abs(c.depth_mm),
                    .stiffness_n_per_m = def.stiffness_kpa_per_mm * a,
                    .strength_mn = def.strength_kpa * a,
                    .area_mm2 = a});
  }
}

}  // namespace

AttachmentId create_attachment(World& world, const AttachmentDef& def) {
  const BodyId a{def.body_a, def.generation_a}, b{def.body_b, def.generation_b};
  const Body& ba = body(world, a);
  const Body& bb = body(world, b);
  const std::string name = def.name.empty() ? ba.name + "-" + bb.name : def.name;
  if (a == b) throw refused("attachment '" + name + "': a body cannot be attached to itself");
  const auto positive = [&](double v, const char* key) {
    if (!(v > 0.0) || !std::isfinite(v))
      throw refused(
          fmt::format("attachment '{}': {} must be a positive number, got {}", name, key, v));
  };
  positive(def.reach_mm, "reach_mm");
  positive(def.stiffness_kpa_per_mm, "stiffness_kpa_per_mm");
  positive(def.strength_kpa, "strength_kpa");
  Attachment at{.name = name,
                .body_a = a.index,
                .body_b = b.index,
                .generation_a = a.generation,
                .generation_b = b.generation,
                .ties = {},
                .def = def};
  at.def.name = name;
  tie_nodes(world, a.index, b.index, def, at.ties);
  tie_nodes(world, b.index, a.index, def, at.ties);
  if (at.ties.empty())
    throw refused(fmt::format(
        "attachment '{}': the skins of '{}' and '{}' come nowhere within reach_mm = {:g} mm of "
        "each other at rest: nothing to attach",
        name, ba.name, bb.name, def.reach_mm));
  size_t slot = 0;
  while (slot < world.attachments.size() && world.attachments[slot].alive) ++slot;
  if (slot == world.attachments.size()) world.attachments.emplace_back();
  AttachmentSlot& s = world.attachments[slot];
  s.attachment = std::move(at);
  s.alive = true;
  return {static_cast<int32_t>(slot), s.generation};
}

const Attachment& attachment(const World& world, AttachmentId id) {
  if (id.index < 0 || static_cast<size_t>(id.index) >= world.attachments.size() ||
      !world.attachments[static_cast<size_t>(id.index)].alive ||
      world.attachments[static_cast<size_t>(id.index)].generation != id.generation)
    throw refused("attachment handle " + handle_text(id.index, id.generation) +
                  " is stale: it names no attachment of this world");
  return world.attachments[static_cast<size_t>(id.index)].attachment;
}

Attachment& attachment(World& world, AttachmentId id) {
  return const_cast<Attachment&>(attachment(static_cast<const World&>(world), id));
}

TieCount count_ties(const World& world) {
  TieCount n;
  for (const AttachmentSlot& s : world.attachments) {
    if (!s.alive) continue;
    for (const Tie& t : s.attachment.ties) {
      ++n.total;
      n.divided += t.divided ? 1 : 0;
      n.torn += t.torn ? 1 : 0;
    }
  }
  return n;
}

double distance_to_sweep(const BladeSweep& s, const Eigen::Vector3d& p) {
  const auto to_triangle = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                               const Eigen::Vector3d& c) {
    const Eigen::Vector3d w = geometry::closest_on_triangle(p, a, b, c);
    return (p - (w.x() * a + w.y() * b + w.z() * c)).norm();
  };
  return std::min(to_triangle(s.a0, s.b0, s.b1), to_triangle(s.a0, s.b1, s.a1));
}

std::pair<Eigen::Vector3d, Eigen::Vector3d> tie_ends(const World& world, const Tie& tie) {
  const Body& nb = world.bodies[static_cast<size_t>(tie.node_body)].body;
  const Body& sb = world.bodies[static_cast<size_t>(tie.surface_body)].body;
  return {nb.sim.x.row(tie.node).transpose(), detail::point_on(sb, tie.corners, tie.weights)};
}

int32_t divide_ties(World& world, const BladeSweep& sweep, double reach_mm) {
  int32_t divided = 0;
  for (AttachmentSlot& slot : world.attachments) {
    if (!slot.alive) continue;
    for (Tie& t : slot.attachment.ties) {
      if (!t.active()) continue;
      const auto [p, q] = tie_ends(world, t);
      if (distance_to_sweep(sweep, 0.5 * (p + q)) <= std::max(reach_mm, 0.5 * (p - q).norm())) {
        t.divided = true;
        ++divided;
      }
    }
  }
  return divided;
}

World one_body_world(BodyDef def) {
  World w;
  w.contact.enabled = false;
  w.contact.self_contact = false;
  create_body(w, std::move(def));
  return w;
}

void reset(World& world) {
  for (BodySlot& s : world.bodies)
    if (s.alive) {
      interact::ToolDriver& d = s.body.tools;
      // Whatever a grasper holds is let go first: a held node stays fixed in the simulation
      // until opened, and the driver that knows it is about to be cleared.
      for (interact::Grasp& g : d.grasps)
        if (!g.nodes.empty()) interact::open_jaws(s.body.sim, g);
      if (!d.hand.nodes.empty()) interact::open_jaws(s.body.sim, d.hand);
      sim::reset(s.body.sim);
      d = interact::ToolDriver{.tools = std::move(d.tools), .routing = d.routing};
    }
  for (AttachmentSlot& s : world.attachments)
    for (Tie& t : s.attachment.ties) {
      t.divided = t.torn = false;
      t.force_mn = 0.0;
    }
  world.time_s = 0.0;
  world.steps = 0;
}

}  // namespace lamina::world
