#include "lamina/model/compute_rings.h"

#include <gtest/gtest.h>

#include <set>

#include "lamina/geometry/make_phantom.h"
#include "lamina/geometry/mesh_measures.h"
#include "lamina/model/build_model.h"
#include "support/meshes.h"

namespace {

using namespace lamina;

// A one-layer model from a mesh: edges as intra-layer springs.
Model model_of(const SurfaceMesh& mesh) {
  Model m;
  m.X = mesh.V;
  m.layers.push_back(
      {.first_node = 0, .node_count = static_cast<int32_t>(mesh.V.rows()), .F = mesh.F});
  m.layer_of.assign(static_cast<size_t>(mesh.V.rows()), 0);
  for (const auto& [a, b] : geometry::mesh_edges(mesh.F)) {
    m.springs.i.push_back(a);
    m.springs.j.push_back(b);
    m.springs.rest_length_mm.push_back(1.0);
    m.springs.stiffness_n_per_m.push_back(1.0);
    m.springs.kind.push_back(SpringKind::kIntraLayer);
  }
  return m;
}

TEST(ComputeRings, OctahedronRings) {
  const Rings r = model::compute_rings(model_of(test::octahedron()), 4);
  ASSERT_EQ(r.offsets.size(), 6u * 4u + 1u);
  for (int32_t v = 0; v < 6; ++v) {
    EXPECT_EQ(r.ring_size(v, 0), 1);
    EXPECT_EQ(r.ring(v, 0)[0], v);
    EXPECT_EQ(r.ring_size(v, 1), 4);  // every octahedron vertex has 4 neighbours
    EXPECT_EQ(r.ring_size(v, 2), 1);  // and one opposite vertex
    EXPECT_EQ(r.ring_size(v, 3), 0);
  }
  EXPECT_EQ(r.ring(0, 2)[0], 1);  // +x is opposite -x
}

TEST(ComputeRings, AreBreadthFirstLevelsWithinTheLayerOnAModel) {
  const LabelVolume v = geometry::make_phantom({.spacing_mm = {3, 3, 3}});
  const model::BuildResult b = model::build_model(v, {.skin_vertices = 400, .locality = 5});
  const Model& m = b.model;
  const Rings& r = m.rings;
  ASSERT_EQ(r.locality, 5);
  // Neighbour sets from the intra-layer springs.
  std::vector<std::set<int32_t>> nb(static_cast<size_t>(m.node_count()));
  for (size_t e = 0; e < m.springs.size(); ++e)
    if (m.springs.kind[e] == SpringKind::kIntraLayer) {
      nb[m.springs.i[e]].insert(m.springs.j[e]);
      nb[m.springs.j[e]].insert(m.springs.i[e]);
    }
  for (int32_t v0 = 0; v0 < m.node_count(); ++v0) {
    std::vector<int> level(static_cast<size_t>(m.node_count()), -1);
    for (int32_t k = 0; k < r.locality; ++k)
      for (int64_t n = 0; n < r.ring_size(v0, k); ++n) {
        const int32_t u = r.ring(v0, k)[n];
        ASSERT_EQ(level[u], -1) << "node in two rings";
        level[u] = k;
        ASSERT_EQ(m.layer_of[u], m.layer_of[v0]);
        if (n > 0) ASSERT_LT(r.ring(v0, k)[n - 1], u);  // sorted
      }
    ASSERT_EQ(level[v0], 0);
    // Level k nodes: some neighbour at level k-1, none at a level below k-1; and every
    // unlevelled neighbour of a level k node (k < N-1) would be at level k+1, which is stored.
    for (int32_t u = 0; u < m.node_count(); ++u) {
      if (level[u] <= 0) continue;
      bool parent = false;
      for (int32_t w : nb[u]) {
        ASSERT_TRUE(level[w] == -1 || level[w] >= level[u] - 1);
        parent |= level[w] == level[u] - 1;
      }
      ASSERT_TRUE(parent);
    }
    for (int32_t u = 0; u < m.node_count(); ++u)
      if (level[u] >= 0 && level[u] < r.locality - 1)
        for (int32_t w : nb[u]) ASSERT_NE(level[w], -1);
  }
  // Compact: far fewer entries than a dense #nodes^2 matrix.
  EXPECT_LT(r.members.size(), static_cast<size_t>(m.node_count()) * 200);
}

}  // namespace
