// Contact between skins: every skin node inside a skin (another body's, or its own away from
// itself), and the nearest point of that skin (couplings.cpp holds each one there).
#include <algorithm>
#include <cmath>

#include "world_work.h"

namespace lamina::world::detail {
namespace {

bool boxes_meet(const SkinGrid& a, const SkinGrid& b, double reach) {
  return (a.lo.array() - reach <= b.hi.array()).all() &&
         (b.lo.array() - reach <= a.hi.array()).all();
}

}  // namespace

void find_contacts(World& world, bool measure_rest, bool every_node) {
  WorldWork& w = world.work();
  const ContactOptions& o = world.contact;
  w.contacts.clear();
  const auto slots = static_cast<int32_t>(world.bodies.size());
  w.grids.resize(world.bodies.size());
  w.grid_ready.assign(world.bodies.size(), 0);
  // A grid is built when a node first needs it (at rest every skin's, for the boxes and the
  // overlaps); the skins' farthest moves bound who can need one.
  const auto grid = [&](int32_t t) -> const SkinGrid& {
    SkinGrid& g = w.grids[static_cast<size_t>(t)];
    if (!w.grid_ready[static_cast<size_t>(t)]) {
      const Body& b = world.bodies[static_cast<size_t>(t)].body;
      build_skin_grid(*b.model, measure_rest ? b.model->X : b.sim.x, o.reach_mm, g);
      w.grid_ready[static_cast<size_t>(t)] = 1;
    }
    return g;
  };
  if (measure_rest)
    for (int32_t s = 0; s < slots; ++s)
      if (world.bodies[static_cast<size_t>(s)].alive) grid(s);
  Contact c;
  // The nearest triangle c of node n (body s) in body t's skin is a contact if it lies deeper
  // than the node's rest overlap.
  const auto keep = [&](int32_t s, int32_t n, int32_t t) {
    const Body& nb = world.bodies[static_cast<size_t>(s)].body;
    const double allowance = measure_rest ? 0.0 : nb.rest_overlap_mm[static_cast<size_t>(n)];
    // A node the contact pushed out last step stays in contact a margin outside the skin.
    const bool held = !measure_rest && w.pushed.size() > static_cast<size_t>(s) &&
                      !w.pushed[static_cast<size_t>(s)].empty() &&
                      w.pushed[static_cast<size_t>(s)][static_cast<size_t>(n)] != 0;
    if (c.depth_mm - allowance <= (held ? -o.margin_mm : 0.0)) return;
    c.body = s;
    c.node = n;
    c.other = t;
    c.depth_mm -= allowance;
    w.contacts.push_back(c);
  };
  for (int32_t s = 0; s < slots; ++s) {
    const BodySlot& node_slot = world.bodies[static_cast<size_t>(s)];
    if (!node_slot.alive) continue;
    const Body& nb = node_slot.body;
    const Eigen::MatrixX3d& nx = measure_rest ? nb.model->X : nb.sim.x;
    const ModelLayer& skin = nb.model->layers.front();
    for (int32_t t = 0; t < slots; ++t) {
      const BodySlot& other_slot = world.bodies[static_cast<size_t>(t)];
      if (!other_slot.alive) continue;
      const bool self = s == t;
      if (self && !o.self_contact) continue;
      const Body& ob = other_slot.body;
      const Eigen::MatrixX3d& ox = measure_rest ? ob.model->X : ob.sim.x;
      SkinGrid& own = w.grids[static_cast<size_t>(t)];
      if (self && own.mean_edge_mm <= 0.0) own.mean_edge_mm = skin_mean_edge(*ob.model);
      const double exclusion = self ? self_exclusion(o, own.mean_edge_mm) : 0.0;
      // Self-contact reaches half as deep: a thin part's far side is not its own inside.
      const double reach = self ? 0.5 * o.reach_mm : o.reach_mm;
      // The step reads the near lists; at rest and for the tests' reference, every node.
      if (!measure_rest && !every_node) {
        const NearLists& near = near_lists_of(world, s, t, exclusion, reach);
        const Eigen::MatrixX3i& F = ob.model->layers.front().F;
        for (size_t i = 0; i < near.nodes.size(); ++i) {
          const int32_t n = skin.first_node + near.nodes[i];
          if (self && nb.rest_overlap_mm[static_cast<size_t>(n)] > 0.0) continue;
          const Eigen::Vector3d p = nx.row(n).transpose();
          double best = reach * reach;
          bool found = false;
          for (int32_t j = near.start[i]; j < near.start[i + 1]; ++j)
            found |= nearer_triangle(F, ox, near.triangles[static_cast<size_t>(j)], p, best, c);
          if (found) keep(s, n, t);
        }
        continue;
      }
      int meet = -1;  // whether the skins' boxes meet: asked once a node needs the grids
      for (int32_t n = skin.first_node; n < skin.first_node + skin.node_count; ++n) {
        const Eigen::Vector3d p = nx.row(n).transpose();
        if (meet < 0) meet = self || boxes_meet(grid(s), grid(t), o.reach_mm);
        if (meet == 0) break;
        const SkinGrid& g = grid(t);
        if (!self &&
            ((p.array() < g.lo.array() - reach).any() || (p.array() > g.hi.array() + reach).any()))
          continue;
        // A node of a thin part already behind its own far side at rest takes no self-contact.
        if (self && !measure_rest && nb.rest_overlap_mm[static_cast<size_t>(n)] > 0.0) continue;
        if (nearest_on_skin(*ob.model, ox, g, p, n, self, *nb.model, exclusion, reach, c))
          keep(s, n, t);
      }
    }
  }
}

}  // namespace lamina::world::detail
