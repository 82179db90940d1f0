// A skeleton's graph (vessel_graph.h): its voxels' 26-neighbours found by binary search in the
// sorted voxel list, junction voxels clustered, then each curve walked once from a node.
#include "lamina/geometry/vessel_graph.h"

#include <algorithm>
#include <set>
#include <utility>

#include "vessel_internal.h"

namespace lamina::geometry {
namespace {

using detail::voxel_centre_mm;

// The length of a path through `points` (a node, a branch's voxel centres, a node), each inner
// point first averaged with those within two steps of it: a 26-connected voxel path along a
// slanted line zigzags, and its own length was up to 18% more than the line's (the phantom's
// vessels).
double smoothed_length(const std::vector<Eigen::Vector3d>& points) {
  const auto n = static_cast<int64_t>(points.size());
  double length = 0.0;
  Eigen::Vector3d last = points.front();
  for (int64_t k = 1; k < n; ++k) {
    Eigen::Vector3d p = points[static_cast<size_t>(k)];
    if (k + 1 < n) {
      const int64_t lo = std::max<int64_t>(0, k - 2), hi = std::min<int64_t>(n - 1, k + 2);
      p.setZero();
      for (int64_t q = lo; q <= hi; ++q) p += points[static_cast<size_t>(q)];
      p /= static_cast<double>(hi - lo + 1);
    }
    length += (p - last).norm();
    last = p;
  }
  return length;
}

double median(std::vector<double> values) {
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

}  // namespace

VesselGraph vessel_graph(const Skeleton& skeleton) {
  VesselGraph g;
  g.frame = skeleton.frame;
  const GridFrame& f = skeleton.frame;
  const std::vector<int64_t>& voxels = skeleton.voxels;
  const auto count = static_cast<int32_t>(voxels.size());
  const auto at = [&](int64_t v) {  // the skeleton's index of voxel v, or -1
    const auto it = std::lower_bound(voxels.begin(), voxels.end(), v);
    return it != voxels.end() && *it == v ? static_cast<int32_t>(it - voxels.begin()) : -1;
  };

  // Each voxel's skeleton neighbours (CSR).
  std::vector<int32_t> first(static_cast<size_t>(count) + 1, 0), next;
  for (int32_t s = 0; s < count; ++s) {
    const int64_t v = voxels[static_cast<size_t>(s)];
    const int64_t i = v % f.size[0], j = (v / f.size[0]) % f.size[1],
                  k = v / (f.size[0] * f.size[1]);
    for (int64_t dz = -1; dz <= 1; ++dz)
      for (int64_t dy = -1; dy <= 1; ++dy)
        for (int64_t dx = -1; dx <= 1; ++dx) {
          if ((dx | dy | dz) == 0 || i + dx < 0 || j + dy < 0 || k + dz < 0 ||
              i + dx >= f.size[0] || j + dy >= f.size[1] || k + dz >= f.size[2])
            continue;
          const int32_t w = at(f.index(i + dx, j + dy, k + dz));
          if (w >= 0) next.push_back(w);
        }
    first[static_cast<size_t>(s) + 1] = static_cast<int32_t>(next.size());
  }
  const auto degree = [&](int32_t s) {
    return first[static_cast<size_t>(s) + 1] - first[static_cast<size_t>(s)];
  };

  // Nodes: ends and isolated voxels alone, touching junction voxels together.
  std::vector<int32_t> node_of(static_cast<size_t>(count), -1);
  const auto add_node = [&](std::vector<int32_t> members) {
    VesselGraph::Node n;
    n.position_mm.setZero();
    for (const int32_t s : members) {
      node_of[static_cast<size_t>(s)] = static_cast<int32_t>(g.nodes.size());
      n.voxels.push_back(voxels[static_cast<size_t>(s)]);
      n.position_mm += voxel_centre_mm(f, voxels[static_cast<size_t>(s)]);
      n.radius_mm = std::max<double>(n.radius_mm, skeleton.radius_mm[static_cast<size_t>(s)]);
    }
    n.position_mm /= static_cast<double>(members.size());
    g.nodes.push_back(std::move(n));
  };
  for (int32_t s = 0; s < count; ++s) {
    if (node_of[static_cast<size_t>(s)] >= 0 || degree(s) == 2) continue;
    std::vector<int32_t> members{s};
    if (degree(s) >= 3) {
      node_of[static_cast<size_t>(s)] = 0;  // taken (renumbered by add_node)
      for (size_t m = 0; m < members.size(); ++m)
        for (int32_t e = first[static_cast<size_t>(members[m])];
             e < first[static_cast<size_t>(members[m]) + 1]; ++e) {
          const int32_t w = next[static_cast<size_t>(e)];
          if (degree(w) >= 3 && node_of[static_cast<size_t>(w)] < 0) {
            node_of[static_cast<size_t>(w)] = 0;
            members.push_back(w);
          }
        }
    }
    add_node(std::move(members));
  }

  // Branches: from each node voxel along each neighbour that is no voxel of the same node.
  std::vector<uint8_t> walked(static_cast<size_t>(count), 0);
  std::set<std::pair<int32_t, int32_t>> touching;  // nodes joined without a curve between them
  std::vector<Eigen::Vector3d> path;
  const auto walk = [&](int32_t from, int32_t start) {
    VesselGraph::Branch b;
    b.a = node_of[static_cast<size_t>(from)];
    std::vector<double> radii;
    path.assign(1, g.nodes[static_cast<size_t>(b.a)].position_mm);
    int32_t previous = from, s = start;
    while (node_of[static_cast<size_t>(s)] < 0) {
      walked[static_cast<size_t>(s)] = 1;
      b.voxels.push_back(voxels[static_cast<size_t>(s)]);
      radii.push_back(skeleton.radius_mm[static_cast<size_t>(s)]);
      path.push_back(voxel_centre_mm(f, voxels[static_cast<size_t>(s)]));
      int32_t after = -1;  // the neighbour it did not come from (a curve voxel has two)
      for (int32_t e = first[static_cast<size_t>(s)]; e < first[static_cast<size_t>(s) + 1]; ++e)
        if (next[static_cast<size_t>(e)] != previous) after = next[static_cast<size_t>(e)];
      previous = s;
      s = after;
      if (s == start) break;  // round a loop back to where it began (no node on it)
    }
    b.b = node_of[static_cast<size_t>(s)] >= 0 ? node_of[static_cast<size_t>(s)] : b.a;
    path.push_back(g.nodes[static_cast<size_t>(b.b)].position_mm);
    b.length_mm = smoothed_length(path);
    b.radius_mm = radii.empty() ? std::min(g.nodes[static_cast<size_t>(b.a)].radius_mm,
                                           g.nodes[static_cast<size_t>(b.b)].radius_mm)
                                : median(std::move(radii));
    ++g.nodes[static_cast<size_t>(b.a)].degree;
    ++g.nodes[static_cast<size_t>(b.b)].degree;
    g.branches.push_back(std::move(b));
  };
  for (int32_t s = 0; s < count; ++s) {
    const int32_t n = node_of[static_cast<size_t>(s)];
    if (n < 0) continue;
    for (int32_t e = first[static_cast<size_t>(s)]; e < first[static_cast<size_t>(s) + 1]; ++e) {
      const int32_t w = next[static_cast<size_t>(e)];
      const int32_t m = node_of[static_cast<size_t>(w)];
      if (m == n || walked[static_cast<size_t>(w)] != 0) continue;
      if (m >= 0) {  // two nodes side by side
        if (touching.insert({std::min(n, m), std::max(n, m)}).second) {
          VesselGraph::Branch b;
          b.a = std::min(n, m);
          b.b = std::max(n, m);
          b.length_mm = (g.nodes[static_cast<size_t>(b.a)].position_mm -
                         g.nodes[static_cast<size_t>(b.b)].position_mm)
                            .norm();
          b.radius_mm = std::min(g.nodes[static_cast<size_t>(b.a)].radius_mm,
                                 g.nodes[static_cast<size_t>(b.b)].radius_mm);
          ++g.nodes[static_cast<size_t>(b.a)].degree;
          ++g.nodes[static_cast<size_t>(b.b)].degree;
          g.branches.push_back(std::move(b));
        }
        continue;
      }
      walk(s, w);
    }
  }
  // Closed loops with no node: one on the loop's first voxel, then the loop walked from it.
  for (int32_t s = 0; s < count; ++s) {
    if (walked[static_cast<size_t>(s)] != 0 || node_of[static_cast<size_t>(s)] >= 0) continue;
    add_node({s});
    walk(s, next[static_cast<size_t>(first[static_cast<size_t>(s)])]);
  }
  return g;
}

}  // namespace lamina::geometry
