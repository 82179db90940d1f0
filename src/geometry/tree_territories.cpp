// A tree's territories (tree_territories.h): its centreline voxels in flow order as the seeds
// of the distance transform's feature transform over the organ's grid.
#include "lamina/geometry/tree_territories.h"

#include <algorithm>

#include "distance_transform.h"
#include "lamina/core/error.h"

namespace lamina::geometry {

TreeTerritories tree_territories(const Mask& organ, VesselTree tree, const std::string& name) {
  const GridFrame& f = organ.frame;
  if (tree.graph.frame.size != f.size || tree.graph.frame.origin_mm != f.origin_mm)
    throw invalid_input(name, "the vessel tree is of another grid than the organ's mask");
  TreeTerritories t;
  t.name = name;
  t.tree = std::move(tree);
  const VesselGraph& g = t.tree.graph;

  // Seeds in flow order: the roots' nodes, then each branch after its parent.
  std::vector<int32_t> node_seed(g.nodes.size(), -1);  // a node's last seed
  const auto add = [&](int64_t voxel, int32_t upstream, int32_t branch) {
    t.seeds.push_back(voxel);
    t.seed_upstream.push_back(upstream);
    t.seed_branch.push_back(branch);
    return static_cast<int32_t>(t.seeds.size() - 1);
  };
  const auto add_node = [&](int32_t n, int32_t upstream, int32_t branch) {
    for (const int64_t v : g.nodes[static_cast<size_t>(n)].voxels)
      upstream = add(v, upstream, branch);
    node_seed[static_cast<size_t>(n)] = upstream;
  };
  for (const int32_t r : t.tree.roots) {
    // A root's voxels count for its widest branch.
    int32_t widest = -1;
    for (size_t b = 0; b < g.branches.size(); ++b)
      if ((g.branches[b].a == r || g.branches[b].b == r) &&
          (widest < 0 ||
           g.branches[b].radius_mm > g.branches[static_cast<size_t>(widest)].radius_mm))
        widest = static_cast<int32_t>(b);
    add_node(r, -1, widest);
  }
  for (const int32_t b : t.tree.order) {
    const VesselGraph::Branch& br = g.branches[static_cast<size_t>(b)];
    const int32_t from = t.tree.from_node[static_cast<size_t>(b)];
    int32_t up = node_seed[static_cast<size_t>(from)];
    if (from == br.a)
      for (const int64_t v : br.voxels) up = add(v, up, b);
    else
      for (auto it = br.voxels.rbegin(); it != br.voxels.rend(); ++it) up = add(*it, up, b);
    const int32_t to = from == br.a ? br.b : br.a;
    if (t.tree.reached_by[static_cast<size_t>(to)] == b) add_node(to, up, b);
  }

  // The feature transform from the seeds inside the organ's grid (all of them: the grid is the
  // vessel's too).
  std::vector<int32_t> seed_at(static_cast<size_t>(f.voxel_count()), -1);
  std::vector<uint8_t> seeded(seed_at.size(), 0);
  bool any_inside = false;
  for (size_t s = 0; s < t.seeds.size(); ++s) {
    const auto v = static_cast<size_t>(t.seeds[s]);
    seed_at[v] = static_cast<int32_t>(s);
    seeded[v] = 1;
    any_inside = any_inside || organ.inside[v] != 0;
  }
  if (!any_inside) throw invalid_input(name, "no voxel of the vessel's tree lies inside the organ");
  const std::vector<int64_t> nearest = detail::nearest_foreground(f, seeded);
  t.seed_of.assign(seed_at.size(), -1);
  t.branch_voxels.assign(g.branches.size(), 0);
  for (size_t v = 0; v < seed_at.size(); ++v) {
    if (organ.inside[v] == 0) continue;
    const int32_t s = seed_at[static_cast<size_t>(nearest[v])];
    t.seed_of[v] = s;
    const int32_t b = t.seed_branch[static_cast<size_t>(s)];
    if (b >= 0) ++t.branch_voxels[static_cast<size_t>(b)];
  }
  return t;
}

}  // namespace lamina::geometry
