// Rooting a vessel graph (vessel_tree.h): pieces found by union-find over the nodes, gaps
// bridged from a piece's ends to the nearest centreline of another piece, a root per piece at the
// organ's outside, flow directions by Dijkstra from the roots along the branches' lengths.
#include "lamina/geometry/vessel_tree.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <queue>

#include "lamina/core/error.h"
#include "vessel_internal.h"

namespace lamina::geometry {
namespace {

using detail::near_inside;
using detail::near_outside;
using detail::Pieces;
using detail::voxel_centre_mm;

// Splits branch `b` at its voxel `q` into two joined by a new node there; returns the node.
int32_t split_branch(VesselGraph& g, int32_t b, size_t q) {
  VesselGraph::Branch old = g.branches[static_cast<size_t>(b)];
  const auto node = static_cast<int32_t>(g.nodes.size());
  VesselGraph::Node n;
  n.position_mm = voxel_centre_mm(g.frame, old.voxels[q]);
  n.radius_mm = old.radius_mm;
  n.degree = 2;
  n.voxels = {old.voxels[q]};
  g.nodes.push_back(n);
  const double share = static_cast<double>(q) / static_cast<double>(old.voxels.size());
  VesselGraph::Branch first = old, second = old;
  first.b = node;
  first.voxels.assign(old.voxels.begin(), old.voxels.begin() + static_cast<std::ptrdiff_t>(q));
  first.length_mm = share * old.length_mm;
  second.a = node;
  second.voxels.assign(old.voxels.begin() + static_cast<std::ptrdiff_t>(q) + 1, old.voxels.end());
  second.length_mm = old.length_mm - first.length_mm;
  g.branches[static_cast<size_t>(b)] = first;
  g.branches.push_back(second);
  return node;
}

}  // namespace

// Joins each piece's ends to the nearest centreline of another piece within reach, nearest gaps
// first, each pair of pieces once.
int32_t bridge_gaps(VesselGraph& g, double max_gap_mm) {
  Pieces pieces(g.nodes.size());
  for (const auto& b : g.branches) pieces.join(b.a, b.b);
  // Every centreline point: a node (voxel -1) or a branch's voxel (and a node of its piece).
  struct Point {
    Eigen::Vector3d p;
    int32_t node;
    int64_t voxel;
  };
  std::vector<Point> points;
  for (size_t n = 0; n < g.nodes.size(); ++n)
    points.push_back({g.nodes[n].position_mm, static_cast<int32_t>(n), -1});
  for (const auto& b : g.branches)
    for (const int64_t v : b.voxels) points.push_back({voxel_centre_mm(g.frame, v), b.a, v});
  std::vector<double> reach(g.nodes.size(), max_gap_mm);
  for (const auto& b : g.branches)
    for (const int32_t n : {b.a, b.b})
      reach[static_cast<size_t>(n)] =
          std::max(reach[static_cast<size_t>(n)], max_gap_mm + b.radius_mm);
  struct Gap {
    double d;
    int32_t end;
    size_t point;
  };
  std::vector<Gap> gaps;
  for (size_t n = 0; n < g.nodes.size(); ++n) {
    if (g.nodes[n].degree > 1) continue;
    const int32_t own = pieces.find(static_cast<int32_t>(n));
    Gap best{reach[n], -1, 0};
    for (size_t q = 0; q < points.size(); ++q) {
      const double d = (points[q].p - g.nodes[n].position_mm).norm();
      if (d < best.d && pieces.find(points[q].node) != own) best = {d, static_cast<int32_t>(n), q};
    }
    if (best.end >= 0) gaps.push_back(best);
  }
  std::sort(gaps.begin(), gaps.end(), [](const Gap& a, const Gap& b) { return a.d < b.d; });
  int32_t bridged = 0;
  for (const Gap& gap : gaps) {
    const Point& to = points[gap.point];
    if (pieces.find(gap.end) == pieces.find(to.node)) continue;
    int32_t node = to.node;
    if (to.voxel >= 0)  // onto a branch's middle: split it there (it may be split already)
      for (size_t b = 0; b < g.branches.size(); ++b) {
        const auto& vox = g.branches[b].voxels;
        const auto it = std::find(vox.begin(), vox.end(), to.voxel);
        if (it == vox.end()) continue;
        node = split_branch(g, static_cast<int32_t>(b), static_cast<size_t>(it - vox.begin()));
        pieces.up.push_back(node);
        pieces.join(node, to.node);
        break;
      }
    VesselGraph::Branch bridge;
    bridge.a = gap.end;
    bridge.b = node;
    bridge.length_mm = gap.d;
    bridge.radius_mm = std::min(g.nodes[static_cast<size_t>(gap.end)].radius_mm,
                                g.nodes[static_cast<size_t>(node)].radius_mm);
    ++g.nodes[static_cast<size_t>(gap.end)].degree;
    ++g.nodes[static_cast<size_t>(node)].degree;
    g.branches.push_back(bridge);
    pieces.join(gap.end, node);
    ++bridged;
  }
  return bridged;
}

VesselTree vessel_tree(VesselGraph graph, const Mask& organ, const std::string& name,
                       const VesselTreeOptions& options) {
  VesselTree t;
  t.graph = std::move(graph);
  VesselGraph& g = t.graph;
  t.bridged_gaps = bridge_gaps(g, options.max_gap_mm);
  const size_t n_nodes = g.nodes.size(), n_branches = g.branches.size();

  // Each node's widest branch, and the pieces with their centreline lengths.
  const std::vector<double> widest = detail::widest_branch_at_nodes(g);
  Pieces pieces(n_nodes);
  for (const auto& b : g.branches) pieces.join(b.a, b.b);
  std::vector<double> piece_mm(n_nodes, 0.0);
  for (const auto& b : g.branches) piece_mm[static_cast<size_t>(pieces.find(b.a))] += b.length_mm;

  // A root per piece: the widest node next to the outlet when one is given (the vena cava for
  // the hepatic veins), else (or for a piece that does not reach it) the widest node that
  // reaches the organ's outside.
  const double voxel_mm =
      std::max({organ.frame.spacing_mm[0], organ.frame.spacing_mm[1], organ.frame.spacing_mm[2]});
  const auto widest_root = [&](const auto& qualifies) {
    std::vector<int32_t> root_of(n_nodes, -1);
    for (size_t n = 0; n < n_nodes; ++n) {
      if (widest[n] <= 0.0) continue;  // a lone voxel: no branch to feed
      const auto p = static_cast<size_t>(pieces.find(static_cast<int32_t>(n)));
      const int32_t best = root_of[p];
      if (best >= 0 && widest[static_cast<size_t>(best)] >= widest[n]) continue;
      if (qualifies(g.nodes[n].position_mm, widest[n] + 2.0 * voxel_mm))
        root_of[p] = static_cast<int32_t>(n);
    }
    return root_of;
  };
  std::vector<int32_t> root_of = widest_root(
      [&](const Eigen::Vector3d& q, double reach) { return near_outside(organ, q, reach); });
  std::vector<uint8_t> at_outlet_piece(n_nodes, 0);
  if (options.outlet != nullptr) {
    const std::vector<int32_t> at_outlet = widest_root([&](const Eigen::Vector3d& q, double reach) {
      return near_inside(*options.outlet, q, reach);
    });
    for (size_t p = 0; p < n_nodes; ++p)
      if (at_outlet[p] >= 0) {
        root_of[p] = at_outlet[p];
        at_outlet_piece[p] = 1;
      }
  }
  for (size_t p = 0; p < n_nodes; ++p)
    if (root_of[p] >= 0 && (piece_mm[p] >= options.least_tree_mm || t.roots.empty()))
      t.roots.push_back(root_of[p]);
  // Small pieces rooted only when nothing else is: drop those again when a larger one has a root.
  std::erase_if(t.roots, [&](int32_t r) {
    return piece_mm[static_cast<size_t>(pieces.find(r))] < options.least_tree_mm &&
           std::any_of(t.roots.begin(), t.roots.end(), [&](int32_t o) {
             return piece_mm[static_cast<size_t>(pieces.find(o))] >= options.least_tree_mm;
           });
  });
  // Counted among the roots kept (a small piece's outlet root dropped above is none).
  for (const int32_t r : t.roots)
    t.outlet_roots += at_outlet_piece[static_cast<size_t>(pieces.find(r))];
  if (t.roots.empty())
    throw invalid_input(name,
                        "no root found: the vessel does not reach the organ's surface (where its "
                        "trunk enters or leaves the organ); is it the right label?");

  // Flow directions: shortest paths along the branches from the roots.
  std::vector<std::vector<int32_t>> at(n_nodes);
  for (size_t b = 0; b < n_branches; ++b) {
    at[static_cast<size_t>(g.branches[b].a)].push_back(static_cast<int32_t>(b));
    if (g.branches[b].b != g.branches[b].a)
      at[static_cast<size_t>(g.branches[b].b)].push_back(static_cast<int32_t>(b));
  }
  std::vector<double> dist(n_nodes, INFINITY);
  std::vector<int32_t> via(n_nodes, -1);  // the branch that reached the node
  using Item = std::pair<double, int32_t>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
  for (const int32_t r : t.roots) {
    dist[static_cast<size_t>(r)] = 0.0;
    queue.emplace(0.0, r);
  }
  while (!queue.empty()) {
    const auto [d, n] = queue.top();
    queue.pop();
    if (d > dist[static_cast<size_t>(n)]) continue;
    for (const int32_t b : at[static_cast<size_t>(n)]) {
      const auto& br = g.branches[static_cast<size_t>(b)];
      const int32_t o = br.a == n ? br.b : br.a;
      const double nd = d + br.length_mm;
      if (nd < dist[static_cast<size_t>(o)]) {
        dist[static_cast<size_t>(o)] = nd;
        via[static_cast<size_t>(o)] = b;
        queue.emplace(nd, o);
      }
    }
  }
  t.reached_by = via;
  t.from_node.assign(n_branches, -1);
  t.parent.assign(n_branches, -1);
  for (size_t b = 0; b < n_branches; ++b) {
    const auto& br = g.branches[b];
    const double da = dist[static_cast<size_t>(br.a)], db = dist[static_cast<size_t>(br.b)];
    if (!std::isfinite(da) && !std::isfinite(db)) {
      t.unrooted_mm += br.length_mm;
      continue;
    }
    const int32_t from = da <= db ? br.a : br.b;
    t.from_node[b] = from;
    const int32_t up = via[static_cast<size_t>(from)];
    t.parent[b] = up == static_cast<int32_t>(b) ? -1 : up;
  }
  // Each branch after its parent: by its from-node's distance, then the branch that reached a
  // node before the others leaving it.
  for (size_t b = 0; b < n_branches; ++b)
    if (t.from_node[b] >= 0) t.order.push_back(static_cast<int32_t>(b));
  std::stable_sort(t.order.begin(), t.order.end(), [&](int32_t x, int32_t y) {
    const double dx = dist[static_cast<size_t>(t.from_node[static_cast<size_t>(x)])];
    const double dy = dist[static_cast<size_t>(t.from_node[static_cast<size_t>(y)])];
    return dx < dy;
  });
  return t;
}

namespace detail {

namespace {

// Whether a voxel of `mask` that is `inside` (or, for !inside, beyond its grid) lies within
// `reach_mm` of `p`.
bool near_voxel(const Mask& mask, const Eigen::Vector3d& p, double reach_mm, bool inside) {
  const GridFrame& f = mask.frame;
  const Eigen::Vector3d o(f.origin_mm[0], f.origin_mm[1], f.origin_mm[2]);
  std::array<int64_t, 3> c{}, r{};
  for (int a = 0; a < 3; ++a) {
    const Eigen::Vector3d axis(f.direction[a], f.direction[3 + a], f.direction[6 + a]);
    c[a] = std::llround((p - o).dot(axis) / f.spacing_mm[a]);
    r[a] = static_cast<int64_t>(std::ceil(reach_mm / f.spacing_mm[a]));
  }
  const double reach2 = reach_mm * reach_mm;
  for (int64_t dk = -r[2]; dk <= r[2]; ++dk)
    for (int64_t dj = -r[1]; dj <= r[1]; ++dj)
      for (int64_t di = -r[0]; di <= r[0]; ++di) {
        const double d2 = std::pow(di * f.spacing_mm[0], 2) + std::pow(dj * f.spacing_mm[1], 2) +
                          std::pow(dk * f.spacing_mm[2], 2);
        if (d2 > reach2) continue;
        const int64_t i = c[0] + di, j = c[1] + dj, k = c[2] + dk;
        if (i < 0 || j < 0 || k < 0 || i >= f.size[0] || j >= f.size[1] || k >= f.size[2]) {
          if (!inside) return true;
          continue;
        }
        if ((mask.inside[static_cast<size_t>(f.index(i, j, k))] != 0) == inside) return true;
      }
  return false;
}

}  // namespace

bool near_outside(const Mask& organ, const Eigen::Vector3d& p, double reach_mm) {
  return near_voxel(organ, p, reach_mm, false);
}

bool near_inside(const Mask& mask, const Eigen::Vector3d& p, double reach_mm) {
  return near_voxel(mask, p, reach_mm, true);
}

}  // namespace detail
}  // namespace lamina::geometry
