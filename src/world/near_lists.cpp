// Near lists: what a step's contact search reads. For each skin node that could reach another
// skin (or its own), the few triangles it could reach, made from a grid at a reference and good
// while the skins have moved less than kNearSlackMm relative to each other: a triangle within
// reach r of a node now was within r + |d_n - d| + max_m |d_m - d| of it at the reference (d_i a
// node's move since, d the second skin's mean move; clearance.cpp has the bound). So the lists,
// made within r + kNearSlackMm, hold every triangle the step can find, and a step tests a
// handful of triangles per listed node instead of a grid bucket's fifty or sixty after building
// the grid again (a three-organ world: 880 nodes searched per step, 58 triangles each, the grid
// built every step; docs/world.md has the profile before and after).
#include <algorithm>
#include <cmath>

#include "world_work.h"

namespace lamina::world::detail {

const NearLists& near_lists_of(World& world, int32_t s, int32_t t, double exclusion_mm,
                               double radius_mm) {
  WorldWork& w = world.work();
  const size_t slots = world.bodies.size();
  if (w.near.size() != slots * slots) w.near.assign(slots * slots, NearLists{});
  NearLists& l = w.near[static_cast<size_t>(s) * slots + static_cast<size_t>(t)];
  const Body& nb = world.bodies[static_cast<size_t>(s)].body;
  const Body& ob = world.bodies[static_cast<size_t>(t)].body;
  const ModelLayer& skin = nb.model->layers.front();
  const ModelLayer& other = ob.model->layers.front();
  if (l.node_model == nb.model.get() && l.skin_model == ob.model.get() &&
      l.exclusion_mm == exclusion_mm && l.radius_mm == radius_mm) {
    const Eigen::RowVector3d shift = skin_mean_move(ob.sim.x, other, l.skin_ref);
    double other_move = 0.0, node_move = 0.0;
    if (!skin_moved_past(ob.sim.x, other, l.skin_ref, shift, kNearSlackMm, other_move) &&
        !skin_moved_past(nb.sim.x, skin, l.node_ref, shift, kNearSlackMm - other_move, node_move))
      return l;
  }
  // Made again: every node the clearances leave within the radius now, with the triangles
  // within the radius (exactly, not their boxes) in the order of F's rows, as the grid's bucket
  // has them, so that the nearest is the same triangle either way.
  const Clearance& clear = clearance_of(world, s, t, exclusion_mm);
  const double within = radius_mm + kNearSlackMm;
  l.node_ref = nb.sim.x.middleRows(skin.first_node, skin.node_count);
  l.skin_ref = ob.sim.x.middleRows(other.first_node, other.node_count);
  l.nodes.clear();
  l.start.assign(1, 0);
  l.triangles.clear();
  const Eigen::MatrixX3i& F = other.F;
  bool grid_made = false;
  Contact scratch;
  for (int32_t k = 0; k < skin.node_count; ++k) {
    const int32_t node = skin.first_node + k;
    const Eigen::Vector3d p = nb.sim.x.row(node).transpose();
    const double own = (p.transpose() - clear.node_ref.row(k) - clear.shift).norm();
    if (static_cast<double>(clear.mm[static_cast<size_t>(k)]) > within + own + clear.other_move_mm)
      continue;
    if (!grid_made) {
      build_skin_grid(*ob.model, ob.sim.x, within, l.grid);
      grid_made = true;
    }
    const uint64_t b = grid_bucket(l.grid, p);
    const size_t first = l.triangles.size();
    for (int32_t n = l.grid.start[b]; n < l.grid.end[b]; ++n) {
      const int32_t f = l.grid.items[static_cast<size_t>(n)];
      if (s == t && own_neighbourhood(*nb.model, f, node, exclusion_mm)) continue;
      double best = within * within;
      if (nearer_triangle(F, ob.sim.x, f, p, best, scratch)) l.triangles.push_back(f);
    }
    if (l.triangles.size() == first) continue;
    l.nodes.push_back(k);
    l.start.push_back(static_cast<int32_t>(l.triangles.size()));
  }
  l.node_model = nb.model.get();
  l.skin_model = ob.model.get();
  l.exclusion_mm = exclusion_mm;
  l.radius_mm = radius_mm;
  ++l.made;
  return l;
}

}  // namespace lamina::world::detail
