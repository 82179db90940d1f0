// The functional remnant (functional_remnant.h): each tree's seeds blocked where the organ is
// resected, their flow followed from the roots, each remnant voxel's nearest seed asked.
#include "lamina/geometry/functional_remnant.h"

#include <algorithm>

#include "lamina/core/error.h"
#include "lamina/geometry/skeletonize.h"
#include "lamina/geometry/vessel_graph.h"

namespace lamina::geometry {

VascularTree vascular_tree(const Mask& organ, const Mask& vessel, const std::string& name,
                           VesselTreeKind kind, int32_t label) {
  bool inside = false;
  for (size_t v = 0; v < vessel.inside.size() && !inside; ++v)
    inside = vessel.inside[v] != 0 && organ.inside[v] != 0;
  if (!inside)
    throw invalid_input(name,
                        "no voxel of the vessel lies inside the organ: is it the right label?");
  VascularTree t;
  t.kind = kind;
  t.label = label;
  t.territories =
      tree_territories(organ, vessel_tree(vessel_graph(skeletonize(vessel)), organ, name), name);
  return t;
}

TumourTerritory tumour_territory(const VascularTree& tree, const std::vector<int64_t>& voxels,
                                 double voxel_ml) {
  const TreeTerritories& t = tree.territories;
  const size_t n_branches = t.tree.graph.branches.size();
  TumourTerritory out;
  out.tree = t.name;
  std::vector<int64_t> count(n_branches, 0);
  for (const int64_t v : voxels) {
    const int32_t s = t.seed_of[static_cast<size_t>(v)];
    if (s >= 0) ++count[static_cast<size_t>(t.seed_branch[static_cast<size_t>(s)])];
  }
  for (size_t b = 0; b < n_branches; ++b)
    if (count[b] > 0) out.branches.push_back(static_cast<int32_t>(b));
  std::stable_sort(out.branches.begin(), out.branches.end(), [&](int32_t x, int32_t y) {
    return count[static_cast<size_t>(x)] > count[static_cast<size_t>(y)];
  });
  if (out.branches.empty()) return out;
  // The nearest common ancestor: the first branch on the first one's way to the root that
  // every other one's way passes through.
  const std::vector<int32_t>& parent = t.tree.parent;
  std::vector<int32_t> passes(n_branches, 0);
  for (const int32_t b : out.branches)
    for (int32_t x = b; x >= 0; x = parent[static_cast<size_t>(x)])
      ++passes[static_cast<size_t>(x)];
  const auto all = static_cast<int32_t>(out.branches.size());
  for (int32_t x = out.branches[0]; x >= 0; x = parent[static_cast<size_t>(x)])
    if (passes[static_cast<size_t>(x)] == all) {
      out.subtree = x;
      break;
    }
  if (out.subtree < 0) return out;
  // Its territory: every branch whose way to the root passes through it.
  for (size_t b = 0; b < n_branches; ++b) {
    if (t.tree.from_node[b] < 0) continue;
    for (int32_t x = static_cast<int32_t>(b); x >= 0; x = parent[static_cast<size_t>(x)])
      if (x == out.subtree) {
        out.territory_ml += static_cast<double>(t.branch_voxels[b]) * voxel_ml;
        break;
      }
  }
  return out;
}

FunctionalRemnant functional_remnant(const std::vector<VascularTree>& trees, const Mask& organ,
                                     const std::vector<uint8_t>& kept, double remnant_ml,
                                     std::vector<uint8_t>& function) {
  FunctionalRemnant out;
  const double voxel_ml = organ.frame.voxel_volume_mm3() / 1000.0;
  const size_t n = organ.inside.size();

  // Per tree: which seeds the resection takes, which still reach the root.
  std::vector<std::vector<uint8_t>> blocked(trees.size()), on(trees.size());
  for (size_t t = 0; t < trees.size(); ++t) {
    const TreeTerritories& tt = trees[t].territories;
    blocked[t].assign(tt.seeds.size(), 0);
    for (size_t s = 0; s < tt.seeds.size(); ++s) {
      const auto v = static_cast<size_t>(tt.seeds[s]);
      blocked[t][s] = organ.inside[v] != 0 && kept[v] == 0 ? 1 : 0;
    }
    on[t] = still_connected(tt, blocked[t]);
    (trees[t].kind == VesselTreeKind::kPortal ? out.portal : out.hepatic) = true;
  }

  // One pass over the remnant's voxels: each one's function, and per branch its remnant and
  // lost voxels (a plane that moves asks this again: the territories themselves are fixed).
  std::vector<std::vector<int64_t>> remnant_of(trees.size()), lost_of(trees.size());
  for (size_t t = 0; t < trees.size(); ++t) {
    remnant_of[t].assign(trees[t].territories.tree.graph.branches.size(), 0);
    lost_of[t].assign(remnant_of[t].size(), 0);
  }
  function.assign(n, 0);
  int64_t remnant_voxels = 0, lost_voxels = 0, devascularized = 0, congested = 0;
  for (size_t v = 0; v < n; ++v) {
    if (organ.inside[v] == 0 || kept[v] == 0) continue;
    ++remnant_voxels;
    uint8_t l = 0;  // bit 0 devascularized, bit 1 congested
    for (size_t t = 0; t < trees.size(); ++t) {
      const TreeTerritories& tt = trees[t].territories;
      const int32_t s = tt.seed_of[v];
      if (s < 0) continue;
      const auto b = static_cast<size_t>(tt.seed_branch[static_cast<size_t>(s)]);
      ++remnant_of[t][b];
      if (on[t][static_cast<size_t>(s)] != 0) continue;
      ++lost_of[t][b];
      l |= trees[t].kind == VesselTreeKind::kPortal ? 1 : 2;
    }
    function[v] = l == 0   ? kFunctional
                  : l == 1 ? kDevascularized
                  : l == 2 ? kCongested
                           : kDevascularizedCongested;
    lost_voxels += l != 0;
    devascularized += (l & 1) != 0;
    congested += (l & 2) != 0;
  }
  // The remnant's volume splits the voxels the surface passes through; its voxels by centre
  // may hold a little more or less. The lost volumes are the remnant's share of them, so that
  // they never exceed it.
  const double per_voxel =
      remnant_voxels > 0 ? remnant_ml / static_cast<double>(remnant_voxels) : voxel_ml;
  out.devascularized_ml = static_cast<double>(devascularized) * per_voxel;
  out.congested_ml = static_cast<double>(congested) * per_voxel;
  out.lost_ml = static_cast<double>(lost_voxels) * per_voxel;
  out.functional_ml = remnant_ml - out.lost_ml;

  // Each tree's branches: their volumes, and their state from their seeds (blocked where the
  // surface takes them, cut off downstream of a block).
  for (size_t t = 0; t < trees.size(); ++t) {
    const TreeTerritories& tt = trees[t].territories;
    const VesselGraph& g = tt.tree.graph;
    TreeFate fate;
    fate.name = tt.name;
    fate.kind = trees[t].kind;
    fate.roots = static_cast<int32_t>(tt.tree.roots.size());
    fate.bridged_gaps = tt.tree.bridged_gaps;
    fate.unrooted_mm = tt.tree.unrooted_mm;
    std::vector<int32_t> seeds_of(g.branches.size(), 0), blocked_of(g.branches.size(), 0),
        off_of(g.branches.size(), 0);
    for (size_t s = 0; s < tt.seeds.size(); ++s) {
      const auto b = static_cast<size_t>(tt.seed_branch[s]);
      ++seeds_of[b];
      blocked_of[b] += blocked[t][s];
      off_of[b] += on[t][s] == 0 ? 1 : 0;
    }
    fate.branches.resize(g.branches.size());
    for (size_t b = 0; b < g.branches.size(); ++b) {
      BranchFate& bf = fate.branches[b];
      bf.id = static_cast<int32_t>(b);
      bf.parent = tt.tree.parent[b];
      bf.length_mm = g.branches[b].length_mm;
      bf.radius_mm = g.branches[b].radius_mm;
      bf.territory_ml = static_cast<double>(tt.branch_voxels[b]) * voxel_ml;
      bf.remnant_ml = static_cast<double>(remnant_of[t][b]) * per_voxel;
      bf.lost_ml = static_cast<double>(lost_of[t][b]) * per_voxel;
      fate.lost_ml += bf.lost_ml;
      if (tt.tree.from_node[b] < 0)
        bf.state = "unrooted";
      else if (seeds_of[b] > 0 && blocked_of[b] == seeds_of[b])
        bf.state = "resected";
      else if (blocked_of[b] > 0)
        bf.state = "divided";
      else if (off_of[b] > 0)
        bf.state = "cut off";
      else
        bf.state = "kept";
      if (bf.state == "divided") ++fate.divided;
    }
    out.trees.push_back(std::move(fate));
  }
  return out;
}

}  // namespace lamina::geometry
