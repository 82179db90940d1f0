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

double self_exclusion(const ContactOptions& o, const SkinGrid& g) {
  return o.self_exclusion_mm > 0.0 ? o.self_exclusion_mm : 3.0 * g.mean_edge_mm;
}

}  // namespace

void find_contacts(World& world, bool measure_rest) {
  WorldWork& w = world.work();
  const ContactOptions& o = world.contact;
  w.contacts.clear();
  const auto slots = static_cast<int32_t>(world.bodies.size());
  w.grids.resize(world.bodies.size());
  for (int32_t s = 0; s < slots; ++s) {
    BodySlot& slot = world.bodies[static_cast<size_t>(s)];
    if (!slot.alive) continue;
    const Body& b = slot.body;
    build_skin_grid(*b.model, measure_rest ? b.model->X : b.sim.x, o.reach_mm,
                    w.grids[static_cast<size_t>(s)]);
  }
  Contact c;
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
      const SkinGrid& g = w.grids[static_cast<size_t>(t)];
      if (!self && !boxes_meet(w.grids[static_cast<size_t>(s)], g, o.reach_mm)) continue;
      const Body& ob = other_slot.body;
      const Eigen::MatrixX3d& ox = measure_rest ? ob.model->X : ob.sim.x;
      const double exclusion = self ? self_exclusion(o, g) : 0.0;
      // Self-contact reaches half as deep: a thin part's far side is not its own inside.
      const double reach = self ? 0.5 * o.reach_mm : o.reach_mm;
      for (int32_t n = skin.first_node; n < skin.first_node + skin.node_count; ++n) {
        const Eigen::Vector3d p = nx.row(n).transpose();
        if (!self &&
            ((p.array() < g.lo.array() - reach).any() || (p.array() > g.hi.array() + reach).any()))
          continue;
        // A node of a thin part already behind its own far side at rest takes no self-contact.
        if (self && !measure_rest && nb.rest_overlap_mm[static_cast<size_t>(n)] > 0.0) continue;
        if (!nearest_on_skin(*ob.model, ox, g, p, n, self, *nb.model, exclusion, reach, c))
          continue;
        const double allowance = measure_rest ? 0.0 : nb.rest_overlap_mm[static_cast<size_t>(n)];
        // A node the contact pushed out last step stays in contact a margin outside the skin.
        const bool held = !measure_rest && w.pushed.size() > static_cast<size_t>(s) &&
                          !w.pushed[static_cast<size_t>(s)].empty() &&
                          w.pushed[static_cast<size_t>(s)][static_cast<size_t>(n)] != 0;
        if (c.depth_mm - allowance <= (held ? -o.margin_mm : 0.0)) continue;
        c.body = s;
        c.node = n;
        c.other = t;
        c.depth_mm -= allowance;
        w.contacts.push_back(c);
      }
    }
  }
}

}  // namespace lamina::world::detail
