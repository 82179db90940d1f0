#include "lamina/model/summarize_model.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <numeric>

#include "lamina/geometry/mesh_measures.h"
#include "lamina/geometry/remesh.h"
#include "lamina/model/embed_surface.h"

namespace lamina::model {

SurfaceMesh layer_mesh(const Model& model, int32_t layer) {
  return layer_mesh(model, layer, model.X);
}

SurfaceMesh layer_mesh(const Model& model, int32_t layer, const Eigen::MatrixX3d& x) {
  const ModelLayer& l = model.layers.at(static_cast<size_t>(layer));
  SurfaceMesh m;
  m.V = x.middleRows(l.first_node, l.node_count);
  m.F = l.F.array() - l.first_node;
  return m;
}

ModelSummary summarize_model(const Model& model, const BuildReport* build) {
  ModelSummary s;
  s.nodes = model.node_count();
  s.springs = static_cast<int64_t>(model.springs.size());
  for (SpringKind k : model.springs.kind)
    (k == SpringKind::kIntraLayer   ? s.intra_layer_springs
     : k == SpringKind::kInterLayer ? s.inter_layer_springs
                                    : s.volume_springs)++;
  s.interior_nodes = model.node_count() - model.surface_node_count();
  if (model.has_tets()) s.tets = geometry::measure_tets(model.X, model.tets.T);
  for (const EmbeddedSurface& e : model.embedded) {
    const geometry::MeshQuality q = geometry::measure_mesh({e.V, e.F});
    s.embedded.push_back({.name = e.name,
                          .role = e.role,
                          .label = e.label,
                          .vertices = e.V.rows(),
                          .faces = e.F.rows(),
                          .outside = e.outside,
                          .offset = offset_vertices(e),
                          .max_amplification = max_amplification(e),
                          .volume_ml = q.volume_mm3 / 1000.0,
                          .closed = q.closed,
                          .manifold = q.manifold});
  }
  for (const ModelVesselTree& t : model.trees)
    s.trees.push_back({.name = t.flow.name,
                       .kind = t.flow.kind,
                       .roots = t.flow.roots,
                       .branches = static_cast<int32_t>(t.flow.branches()),
                       .seeds = static_cast<int32_t>(t.flow.seeds()),
                       .bridged_gaps = t.flow.bridged_gaps,
                       .unrooted_mm = t.flow.unrooted_mm});
  s.total_mass_kg = std::accumulate(model.mass_kg.begin(), model.mass_kg.end(), 0.0);
  s.locality = model.rings.locality;
  s.ring_entries = static_cast<int64_t>(model.rings.members.size());
  if (!model.springs.rest_length_mm.empty()) {
    const auto [lo, hi] = std::minmax_element(model.springs.rest_length_mm.begin(),
                                              model.springs.rest_length_mm.end());
    s.min_rest_length_mm = *lo;
    s.max_rest_length_mm = *hi;
  }

  // Connectivity of the spring graph (union-find).
  std::vector<int32_t> parent(static_cast<size_t>(s.nodes));
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (size_t e = 0; e < model.springs.size(); ++e)
    parent[find(model.springs.i[e])] = find(model.springs.j[e]);
  for (int32_t v = 0; v < s.nodes; ++v) s.spring_components += find(v) == v;

  SurfaceMesh outer;
  for (int32_t k = 0; k < model.layer_count(); ++k) {
    LayerSummary ls;
    ls.index = k;
    SurfaceMesh mesh = layer_mesh(model, k);
    ls.quality = geometry::measure_mesh(mesh);
    if (build && static_cast<size_t>(k) < build->layers.size()) {
      ls.nested = build->layers[k].nested;
      ls.min_gap_mm = build->layers[k].min_gap_to_outer_mm;
    } else {
      ls.self_intersecting = geometry::self_intersects(mesh);
      if (k > 0) {
        const geometry::Nesting n = geometry::check_nesting(outer, mesh);
        ls.nested = n.nested();
        ls.min_gap_mm = n.min_gap_mm;
      }
    }
    s.layers.push_back(ls);
    outer = std::move(mesh);
  }
  return s;
}

}  // namespace lamina::model
