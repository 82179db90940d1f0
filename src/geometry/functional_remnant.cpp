// The functional remnant (functional_remnant.h): each tree's seeds blocked where the organ is
// resected, their flow followed from the roots, each remnant voxel's nearest seed asked.
#include "lamina/geometry/functional_remnant.h"

#include <algorithm>

#include "lamina/core/error.h"
#include "lamina/geometry/skeletonize.h"
#include "lamina/geometry/vessel_graph.h"

namespace lamina::geometry {

VascularTree vascular_tree(const Mask& organ, const Mask& vessel, const std::string& source,
                           const std::string& name, VesselTreeKind kind, int32_t label,
                           const Mask* outlet) {
  // Errors say where the tree came from; the territories carry the tree's own name.
  const std::string where = source.empty() ? name : source + ": " + name;
  bool inside = false;
  for (size_t v = 0; v < vessel.inside.size() && !inside; ++v)
    inside = vessel.inside[v] != 0 && organ.inside[v] != 0;
  if (!inside)
    throw invalid_input(where,
                        "no voxel of the vessel lies inside the organ: is it the right label?");
  VascularTree t;
  t.kind = kind;
  t.label = label;
  VesselTreeOptions options;
  options.outlet = outlet;
  t.territories = tree_territories(
      organ, vessel_tree(vessel_graph(skeletonize(vessel)), organ, where, options), where);
  t.territories.name = name;
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

TreeFlow tree_flow(const VascularTree& tree, double voxel_ml) {
  const TreeTerritories& t = tree.territories;
  const VesselGraph& g = t.tree.graph;
  TreeFlow f;
  f.name = t.name;
  f.kind = tree.kind;
  f.roots = static_cast<int32_t>(t.tree.roots.size());
  f.bridged_gaps = t.tree.bridged_gaps;
  f.unrooted_mm = t.tree.unrooted_mm;
  f.seed_upstream = t.seed_upstream;
  f.seed_branch = t.seed_branch;
  f.branch_parent = t.tree.parent;
  for (size_t b = 0; b < g.branches.size(); ++b) {
    f.branch_rooted.push_back(t.tree.from_node[b] >= 0 ? 1 : 0);
    f.branch_length_mm.push_back(g.branches[b].length_mm);
    f.branch_radius_mm.push_back(g.branches[b].radius_mm);
    f.branch_territory_ml.push_back(static_cast<double>(t.branch_voxels[b]) * voxel_ml);
  }
  return f;
}

FunctionalRemnant functional_remnant(const std::vector<VascularTree>& trees, const Mask& organ,
                                     const std::vector<uint8_t>& kept, double remnant_ml,
                                     std::vector<uint8_t>& function) {
  const double voxel_ml = organ.frame.voxel_volume_mm3() / 1000.0;
  // A seed is taken where it lies in the organ on the resected side (a trunk beyond the organ
  // is not).
  std::vector<TreeFlow> flows;
  std::vector<std::vector<uint8_t>> blocked(trees.size());
  TissueCells cells;
  cells.uniform_ml = voxel_ml;
  for (size_t t = 0; t < trees.size(); ++t) {
    const TreeTerritories& tt = trees[t].territories;
    flows.push_back(tree_flow(trees[t], voxel_ml));
    blocked[t].assign(tt.seeds.size(), 0);
    for (size_t s = 0; s < tt.seeds.size(); ++s) {
      const auto v = static_cast<size_t>(tt.seeds[s]);
      blocked[t][s] = organ.inside[v] != 0 && kept[v] == 0 ? 1 : 0;
    }
    cells.seed_of.push_back(&tt.seed_of);
  }
  return functional_remnant(flows, blocked, cells, kept, remnant_ml, function);
}

FunctionalRemnant functional_remnant(const std::vector<TreeFlow>& trees,
                                     const std::vector<std::vector<uint8_t>>& blocked,
                                     const TissueCells& cells, const std::vector<uint8_t>& kept,
                                     double remnant_ml, std::vector<uint8_t>& function) {
  FunctionalRemnant out;
  std::vector<std::vector<uint8_t>> on(trees.size());
  for (size_t t = 0; t < trees.size(); ++t) {
    on[t] = still_connected(trees[t], blocked[t]);
    (trees[t].kind == VesselTreeKind::kPortal ? out.portal : out.hepatic) = true;
  }
  const size_t n = kept.size();
  function.assign(n, 0);
  if (trees.empty()) {
    out.functional_ml = remnant_ml;
    return out;
  }

  // One pass over the remnant's cells: each one's function, and per branch its remnant and
  // lost volume (a plane that moves asks this again: the territories themselves are fixed).
  std::vector<std::vector<double>> remnant_of(trees.size()), lost_of(trees.size());
  for (size_t t = 0; t < trees.size(); ++t) {
    remnant_of[t].assign(trees[t].branches(), 0.0);
    lost_of[t].assign(trees[t].branches(), 0.0);
  }
  const std::vector<int32_t>& first = *cells.seed_of[0];  // -1: outside the organ
  double remnant = 0.0, lost = 0.0, devascularized = 0.0, congested = 0.0;
  for (size_t c = 0; c < n; ++c) {
    if (first[c] < 0 || kept[c] == 0) continue;
    const double w = cells.cell_ml != nullptr ? (*cells.cell_ml)[c] : cells.uniform_ml;
    remnant += w;
    uint8_t l = 0;  // bit 0 devascularized, bit 1 congested
    for (size_t t = 0; t < trees.size(); ++t) {
      const int32_t s = (*cells.seed_of[t])[c];
      if (s < 0) continue;
      const auto b = static_cast<size_t>(trees[t].seed_branch[static_cast<size_t>(s)]);
      remnant_of[t][b] += w;
      if (on[t][static_cast<size_t>(s)] != 0) continue;
      lost_of[t][b] += w;
      l |= trees[t].kind == VesselTreeKind::kPortal ? 1 : 2;
    }
    function[c] = l == 0   ? kFunctional
                  : l == 1 ? kDevascularized
                  : l == 2 ? kCongested
                           : kDevascularizedCongested;
    if (l != 0) lost += w;
    if ((l & 1) != 0) devascularized += w;
    if ((l & 2) != 0) congested += w;
  }
  // The remnant's volume splits the cells the surface passes through; its cells by centre may
  // hold a little more or less. The lost volumes are the remnant's share of them.
  const double scale = remnant > 0.0 ? remnant_ml / remnant : 1.0;
  out.devascularized_ml = devascularized * scale;
  out.congested_ml = congested * scale;
  out.lost_ml = lost * scale;
  out.functional_ml = remnant_ml - out.lost_ml;

  // Each tree's branches: their volumes, and their state from their seeds (blocked where the
  // surface takes them, cut off downstream of a block).
  for (size_t t = 0; t < trees.size(); ++t) {
    const TreeFlow& f = trees[t];
    TreeFate fate;
    fate.name = f.name;
    fate.kind = f.kind;
    fate.roots = f.roots;
    fate.bridged_gaps = f.bridged_gaps;
    fate.unrooted_mm = f.unrooted_mm;
    std::vector<int32_t> seeds_of(f.branches(), 0), blocked_of(f.branches(), 0),
        off_of(f.branches(), 0);
    for (size_t s = 0; s < f.seeds(); ++s) {
      const auto b = static_cast<size_t>(f.seed_branch[s]);
      ++seeds_of[b];
      blocked_of[b] += blocked[t][s];
      off_of[b] += on[t][s] == 0 ? 1 : 0;
    }
    fate.branches.resize(f.branches());
    for (size_t b = 0; b < f.branches(); ++b) {
      BranchFate& bf = fate.branches[b];
      bf.id = static_cast<int32_t>(b);
      bf.parent = f.branch_parent[b];
      bf.length_mm = f.branch_length_mm[b];
      bf.radius_mm = f.branch_radius_mm[b];
      bf.territory_ml = f.branch_territory_ml[b];
      bf.remnant_ml = remnant_of[t][b] * scale;
      bf.lost_ml = lost_of[t][b] * scale;
      fate.lost_ml += bf.lost_ml;
      if (f.branch_rooted[b] == 0)
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
    fate.connected = std::move(on[t]);
    out.trees.push_back(std::move(fate));
  }
  return out;
}

}  // namespace lamina::geometry
