#include "lamina/model/fill_tetrahedra.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <set>
#include <utility>

#include "lamina/geometry/mesh_measures.h"
#include "lamina/geometry/spatial_sort.h"

namespace lamina::model {

geometry::TetQuality fill_tetrahedra(const geometry::TetOptions& options, Model& m) {
  const int32_t surface_nodes = m.node_count();
  Eigen::Index faces = 0;
  for (const ModelLayer& l : m.layers) faces += l.F.rows();
  Eigen::MatrixX3i F(faces, 3);
  std::vector<int32_t> surface;
  surface.reserve(static_cast<size_t>(faces));
  faces = 0;
  for (int32_t k = 0; k < m.layer_count(); ++k) {
    F.middleRows(faces, m.layers[k].F.rows()) = m.layers[k].F;
    faces += m.layers[k].F.rows();
    surface.insert(surface.end(), m.layers[k].F.rows(), k);
  }
  geometry::ShellTets st = geometry::tetrahedralize_shells(m.X, F, surface, options);

  // Interior nodes after the layers, ordered along a space-filling curve like each layer's, so a
  // node's neighbours are near it in memory.
  const auto interior = static_cast<int32_t>(st.interior_points.rows());
  const std::vector<int32_t> order = geometry::spatial_order(st.interior_points);
  m.X.conservativeResize(surface_nodes + interior, 3);
  for (int32_t p = 0; p < interior; ++p)
    m.X.row(surface_nodes + order[p]) = st.interior_points.row(p);
  m.layer_of.resize(static_cast<size_t>(surface_nodes + interior), kInteriorNode);
  m.fixed.assign(static_cast<size_t>(surface_nodes + interior), 0);
  for (Eigen::Index t = 0; t < st.T.rows(); ++t)
    for (int c = 0; c < 4; ++c)
      if (st.T(t, c) >= surface_nodes)
        st.T(t, c) = surface_nodes + order[st.T(t, c) - surface_nodes];

  // Tetrahedra in the order of their smallest node: a pass over them walks the nodes in order.
  std::vector<Eigen::Index> by_node(static_cast<size_t>(st.T.rows()));
  for (size_t t = 0; t < by_node.size(); ++t) by_node[t] = static_cast<Eigen::Index>(t);
  std::stable_sort(by_node.begin(), by_node.end(), [&](Eigen::Index a, Eigen::Index b) {
    return st.T.row(a).minCoeff() < st.T.row(b).minCoeff();
  });
  m.tets.T.resize(st.T.rows(), 4);
  m.tets.region.resize(by_node.size());
  for (size_t t = 0; t < by_node.size(); ++t) {
    m.tets.T.row(static_cast<Eigen::Index>(t)) = st.T.row(by_node[t]);
    m.tets.region[t] = st.region[static_cast<size_t>(by_node[t])];
  }

  // Springs: every tetrahedron edge once, sorted by (i, j).
  std::set<std::pair<int32_t, int32_t>> layer_edges;
  for (const ModelLayer& l : m.layers)
    for (const auto& [a, b] : geometry::mesh_edges(l.F))
      layer_edges.emplace(std::min(a, b), std::max(a, b));
  std::vector<std::pair<int32_t, int32_t>> edges;
  edges.reserve(6 * static_cast<size_t>(m.tets.size()));
  for (Eigen::Index t = 0; t < m.tets.T.rows(); ++t)
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b)
        edges.emplace_back(std::min(m.tets.T(t, a), m.tets.T(t, b)),
                           std::max(m.tets.T(t, a), m.tets.T(t, b)));
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  Springs& sp = m.springs;
  sp = Springs{};
  for (const auto& [a, b] : edges) {
    sp.i.push_back(a);
    sp.j.push_back(b);
    sp.rest_length_mm.push_back((m.X.row(a) - m.X.row(b)).norm());
    sp.stiffness_n_per_m.push_back(0.0);
    sp.kind.push_back(layer_edges.contains({a, b}) ? SpringKind::kIntraLayer : SpringKind::kVolume);
  }

  // Lumped masses: each tetrahedron's mass in equal quarters to its corners; the total is
  // density x the volume inside the skin.
  m.mass_kg.assign(static_cast<size_t>(m.node_count()), 0.0);
  for (Eigen::Index t = 0; t < m.tets.T.rows(); ++t) {
    const Eigen::Vector3d p0 = m.X.row(m.tets.T(t, 0)), p1 = m.X.row(m.tets.T(t, 1)),
                          p2 = m.X.row(m.tets.T(t, 2)), p3 = m.X.row(m.tets.T(t, 3));
    const double quarter = m.density_kg_per_mm3 * (p1 - p0).cross(p2 - p0).dot(p3 - p0) / 24.0;
    for (int c = 0; c < 4; ++c) m.mass_kg[m.tets.T(t, c)] += quarter;
  }
  return geometry::measure_tets(m.X, m.tets.T);
}

}  // namespace lamina::model
