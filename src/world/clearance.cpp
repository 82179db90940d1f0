// Each skin node's clearance from the skins it could touch, so that a step searches only the
// nodes that have moved far enough to reach one: measured at reference positions, a node n of
// body s and any triangle of body t's skin are at least clearance(n) - |x_n - ref_n| -
// max|x_t - ref_t| apart now, so a node with more than the search's reach left over cannot be in
// contact and is skipped (a Verlet list's bound, per node rather than per pair of elements).
// The references are taken again once the skins have moved half the clearances' cap since: at
// rest never, under a grasper's 24 mm retraction over a second a few times. Before it every node
// was searched every step: 61% of a three-organ step (docs/world.md).
#include <algorithm>
#include <cmath>

#include "world_work.h"

namespace lamina::world::detail {
namespace {

// The farthest a row of `x` (the skin's rows) is from the same row of `ref`, mm.
double farthest_move(const Eigen::MatrixX3d& x, const ModelLayer& skin,
                     const Eigen::MatrixX3d& ref) {
  double worst = 0.0;
  for (int32_t n = 0; n < skin.node_count; ++n)
    worst = std::max(worst, (x.row(skin.first_node + n) - ref.row(n)).squaredNorm());
  return std::sqrt(worst);
}

}  // namespace

const Clearance& clearance_of(World& world, int32_t s, int32_t t, double exclusion_mm) {
  WorldWork& w = world.work();
  const size_t slots = world.bodies.size();
  if (w.clearance.size() != slots * slots) w.clearance.assign(slots * slots, Clearance{});
  Clearance& c = w.clearance[static_cast<size_t>(s) * slots + static_cast<size_t>(t)];
  const Body& nb = world.bodies[static_cast<size_t>(s)].body;
  const Body& ob = world.bodies[static_cast<size_t>(t)].body;
  const ModelLayer& skin = nb.model->layers.front();
  const ModelLayer& other = ob.model->layers.front();
  if (c.node_model == nb.model.get() && c.skin_model == ob.model.get() &&
      c.exclusion_mm == exclusion_mm) {
    c.other_move_mm = farthest_move(ob.sim.x, other, c.skin_ref);
    if (farthest_move(nb.sim.x, skin, c.node_ref) + c.other_move_mm <= 0.5 * kClearanceCapMm)
      return c;
  }
  // Taken again: the exact distance now to the nearest triangle the step's search could find
  // (self: outside the node's neighbourhood), searched within kClearanceCapMm; a node farther
  // than that has the cap.
  c.node_ref = nb.sim.x.middleRows(skin.first_node, skin.node_count);
  c.skin_ref = ob.sim.x.middleRows(other.first_node, other.node_count);
  c.other_move_mm = 0.0;
  build_skin_grid(*ob.model, ob.sim.x, kClearanceCapMm, c.grid);
  c.mm.assign(static_cast<size_t>(skin.node_count), static_cast<float>(kClearanceCapMm));
  Contact found;
  for (int32_t n = 0; n < skin.node_count; ++n) {
    const int32_t node = skin.first_node + n;
    // A node inside the other skin at rest (its rest overlap) is always searched.
    if (!nb.rest_overlap_mm.empty() && nb.rest_overlap_mm[static_cast<size_t>(node)] > 0.0) {
      c.mm[static_cast<size_t>(n)] = 0.0f;
      continue;
    }
    const Eigen::Vector3d p = nb.sim.x.row(node).transpose();
    if (nearest_on_skin(*ob.model, ob.sim.x, c.grid, p, node, s == t, *nb.model, exclusion_mm,
                        kClearanceCapMm, found))
      c.mm[static_cast<size_t>(n)] = found.depth_mm > 0.0 ? 0.0f  // inside: searched
                                                          : static_cast<float>(-found.depth_mm);
  }
  c.node_model = nb.model.get();
  c.skin_model = ob.model.get();
  c.exclusion_mm = exclusion_mm;
  ++c.made;
  return c;
}

}  // namespace lamina::world::detail
