// Each skin node's clearance from the skins it could touch, so that the near lists
// (near_lists.cpp) are made only for the nodes that may reach one: measured at reference
// positions, a node n of body s and any point q of body t's skin (a convex combination of its
// corners) are at least clearance(n) - |d_n - d| - max_m |d_m - d| apart now, where d_i is a
// node's move since the reference and d any one vector: |d_n - d_q| <= |d_n - d| + |d_q - d|
// (a Verlet list's bound, per node rather than per pair of elements). d is skin t's mean move,
// so that what the two skins do together (a grasped organ carried whole, a body's own skin in
// self-contact) costs nothing: only the moves relative to it count. The references are taken
// again once those have reached half the clearances' cap: at rest never, under a grasper's
// retraction a few times (docs/world.md).
#include <algorithm>
#include <cmath>

#include "world_work.h"

namespace lamina::world::detail {
Eigen::RowVector3d skin_mean_move(const Eigen::MatrixX3d& x, const ModelLayer& skin,
                                  const Eigen::MatrixX3d& ref) {
  Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
  for (int32_t n = 0; n < skin.node_count; ++n) sum += x.row(skin.first_node + n) - ref.row(n);
  return skin.node_count > 0 ? Eigen::RowVector3d(sum / skin.node_count) : sum;
}

bool skin_moved_past(const Eigen::MatrixX3d& x, const ModelLayer& skin, const Eigen::MatrixX3d& ref,
                     const Eigen::RowVector3d& shift, double limit, double& worst) {
  double w2 = 0.0;
  const double l2 = limit * limit;
  for (int32_t n = 0; n < skin.node_count; ++n) {
    w2 = std::max(w2, (x.row(skin.first_node + n) - ref.row(n) - shift).squaredNorm());
    if (w2 > l2) return true;
  }
  worst = std::sqrt(w2);
  return false;
}

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
    c.shift = skin_mean_move(ob.sim.x, other, c.skin_ref);
    const double half = 0.5 * kClearanceCapMm;
    double node_move = 0.0;
    if (!skin_moved_past(ob.sim.x, other, c.skin_ref, c.shift, half, c.other_move_mm) &&
        !skin_moved_past(nb.sim.x, skin, c.node_ref, c.shift, half - c.other_move_mm, node_move))
      return c;
  }
  // Taken again: the exact distance now to the nearest triangle the step's search could find
  // (self: outside the node's neighbourhood), searched within kClearanceCapMm; a node farther
  // than that has the cap.
  c.node_ref = nb.sim.x.middleRows(skin.first_node, skin.node_count);
  c.skin_ref = ob.sim.x.middleRows(other.first_node, other.node_count);
  c.other_move_mm = 0.0;
  c.shift.setZero();
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
