// The paper's rings measured in millimetres instead of mesh edges. Hop rings shrink with the
// mesh: the SOFA liver's four rings cover 8.8 mm at paper size and 3.7 mm at 9,064 nodes, so one
// tool's newton lands on a narrow dimple there (docs/validation.md). Rings by distance keep the
// area a tool's force covers whatever the resolution.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <queue>
#include <unordered_map>

#include "lamina/geometry/mesh_measures.h"
#include "lamina/interact/tools.h"

namespace lamina::interact {

double paper_ring_spacing_mm(const Model& model) {
  const double area = geometry::surface_area(model.X, model.layers.at(0).F);
  // A closed mesh of V vertices has 2V - 4 triangles; an equilateral one of edge e has area
  // sqrt(3)/4 e^2.
  constexpr double kPaperTriangles = 2.0 * 1284.0 - 4.0;
  return std::sqrt(4.0 * area / (std::sqrt(3.0) * kPaperTriangles));
}

RoutingOptions resolve_ring_spacing(const RoutingOptions& options, const Model& model) {
  RoutingOptions out = options;
  if (out.ring_spacing_mm == kPaperRingSpacing) out.ring_spacing_mm = paper_ring_spacing_mm(model);
  return out;
}

std::vector<RingMember> rings_by_distance(const Model& model, int32_t v, int32_t locality,
                                          double spacing_mm) {
  // Dijkstra from v over the layer's edges at rest, to (locality - 1/2) spacings: ring r holds
  // the nodes within [r - 1/2, r + 1/2) spacings, so at a spacing equal to the mesh's edge the
  // rings are close to the hop rings (a neighbour one edge away is in ring 1).
  const double reach = (static_cast<double>(locality) - 0.5) * spacing_mm;
  std::unordered_map<int32_t, double> best{{v, 0.0}};
  using Entry = std::pair<double, int32_t>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
  open.emplace(0.0, v);
  std::vector<RingMember> out;
  const bool has_edges = model.rings.locality >= 2;
  while (!open.empty()) {
    const auto [d, u] = open.top();
    open.pop();
    if (d > best[u]) continue;  // a stale entry: u was reached shorter since
    out.push_back({u, static_cast<int32_t>(std::floor(d / spacing_mm + 0.5))});
    if (!has_edges) break;
    const int32_t* next = model.rings.ring(u, 1);
    for (int64_t k = 0; k < model.rings.ring_size(u, 1); ++k) {
      const int32_t w = next[k];
      const double dw = d + (model.X.row(w) - model.X.row(u)).norm();
      if (dw >= reach) continue;
      const auto [it, fresh] = best.try_emplace(w, dw);
      if (!fresh && it->second <= dw) continue;
      it->second = dw;
      open.emplace(dw, w);
    }
  }
  std::sort(out.begin(), out.end(),
            [](const RingMember& a, const RingMember& b) { return a.node < b.node; });
  return out;
}

}  // namespace lamina::interact
