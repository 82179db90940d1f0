// Branch territories (vessel_territories.h): the centrelines' voxels as seeds of an exact
// feature transform (distance_transform.h) over the box holding the organ and the tree.
#include "lamina/geometry/vessel_territories.h"

#include <algorithm>
#include <array>

#include "distance_transform.h"
#include "lamina/core/error.h"

namespace lamina::geometry {

std::vector<int32_t> branch_territories(const Mask& organ, const VesselGraph& graph) {
  const GridFrame& f = organ.frame;
  if (graph.frame.size != f.size)
    throw invalid_input("vessel territories",
                        "the vessel graph is of another grid than the organ's mask");
  std::vector<int32_t> out(static_cast<size_t>(f.voxel_count()), -1);
  if (graph.branches.empty()) return out;

  // Seeds: each branch's voxels, and a junction's voxels for its widest branch.
  std::vector<std::pair<int64_t, int32_t>> seeds;
  std::vector<int32_t> widest(graph.nodes.size(), -1);
  for (size_t b = 0; b < graph.branches.size(); ++b) {
    const VesselGraph::Branch& br = graph.branches[b];
    for (const int64_t v : br.voxels) seeds.emplace_back(v, static_cast<int32_t>(b));
    for (const int32_t n : {br.a, br.b}) {
      int32_t& w = widest[static_cast<size_t>(n)];
      if (w < 0 || graph.branches[static_cast<size_t>(w)].radius_mm < br.radius_mm)
        w = static_cast<int32_t>(b);
    }
  }
  for (size_t n = 0; n < graph.nodes.size(); ++n)
    if (widest[n] >= 0)
      for (const int64_t v : graph.nodes[n].voxels) seeds.emplace_back(v, widest[n]);

  // The box holding the organ and the seeds (a trunk may leave the organ).
  std::array<int64_t, 3> lo{f.size[0], f.size[1], f.size[2]}, hi{-1, -1, -1};
  const auto grow = [&](int64_t v) {
    const std::array<int64_t, 3> ijk{v % f.size[0], (v / f.size[0]) % f.size[1],
                                     v / (f.size[0] * f.size[1])};
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], ijk[a]);
      hi[a] = std::max(hi[a], ijk[a]);
    }
  };
  for (int64_t v = 0; v < f.voxel_count(); ++v)
    if (organ.inside[static_cast<size_t>(v)] != 0) grow(v);
  for (const auto& s : seeds) grow(s.first);
  GridFrame bf = f;
  for (int a = 0; a < 3; ++a) bf.size[a] = hi[a] - lo[a] + 1;
  const auto box_index = [&](int64_t v) {
    return bf.index(v % f.size[0] - lo[0], (v / f.size[0]) % f.size[1] - lo[1],
                    v / (f.size[0] * f.size[1]) - lo[2]);
  };
  std::vector<uint8_t> seeded(static_cast<size_t>(bf.voxel_count()), 0);
  std::vector<int32_t> branch_of(seeded.size(), -1);
  for (const auto& [v, b] : seeds) {
    const auto at = static_cast<size_t>(box_index(v));
    seeded[at] = 1;
    branch_of[at] = b;
  }
  const std::vector<int64_t> nearest = detail::nearest_foreground(bf, seeded);
  for (int64_t k = lo[2]; k <= hi[2]; ++k)
    for (int64_t j = lo[1]; j <= hi[1]; ++j)
      for (int64_t i = lo[0]; i <= hi[0]; ++i) {
        const int64_t v = f.index(i, j, k);
        if (organ.inside[static_cast<size_t>(v)] == 0) continue;
        out[static_cast<size_t>(v)] =
            branch_of[static_cast<size_t>(nearest[static_cast<size_t>(box_index(v))])];
      }
  return out;
}

}  // namespace lamina::geometry
