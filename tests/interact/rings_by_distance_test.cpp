#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>

#include "lamina/interact/tools.h"
#include "lamina/model/build_model.h"
#include "support/sphere_model.h"
#include "support/volumes.h"

namespace {

using namespace lamina;

// The 20 mm sphere at a skin size (the shared one has 600 skin vertices).
Model sphere_at(int32_t skin_vertices) {
  LabelVolume v = test::empty_volume(50, 1.0);
  test::paint_sphere(v, v.frame.to_physical(24.5, 24.5, 24.5), 20.0, 1);
  return model::build_model(
             v, {.display_triangles = 0, .skin_vertices = skin_vertices, .layer_depth_mm = 8.0})
      .model;
}

int32_t top_node(const Model& m) {
  Eigen::Index i = 0;
  m.X.col(2).head(m.layers[0].node_count).maxCoeff(&i);
  return static_cast<int32_t>(i);
}

// The force-weighted distance at rest from the contact of one copy's load: the radius the
// routed force covers.
double load_radius(const Model& m, int32_t contact, double spacing_mm) {
  const interact::ForceRoute r =
      interact::route_force(m, m.X, contact, Eigen::Vector3d(0, 0, -100),
                            {.locality = 4, .penetration_depth = 1, .ring_spacing_mm = spacing_mm});
  EXPECT_TRUE(Eigen::Vector3d(r.forces.colwise().sum()).isApprox(Eigen::Vector3d(0, 0, -100)));
  double sum = 0.0, weighted = 0.0;
  for (size_t k = 0; k < r.nodes.size(); ++k) {
    const double f = r.forces.row(static_cast<Eigen::Index>(k)).norm();
    sum += f;
    weighted += f * (m.X.row(r.nodes[k]) - m.X.row(contact)).norm();
  }
  return weighted / sum;
}

TEST(RingsByDistance, CoverTheSameAreaAtEveryMeshSizeWhereHopRingsShrink) {
  const Model& coarse = test::sphere_model();
  const Model fine = sphere_at(2400);
  ASSERT_GT(fine.layers[0].node_count, 3 * coarse.layers[0].node_count);
  const double hops_coarse = load_radius(coarse, top_node(coarse), 0.0);
  const double hops_fine = load_radius(fine, top_node(fine), 0.0);
  // Four times the vertices, half the edge: the paper's rings cover about half the radius.
  EXPECT_LT(hops_fine, 0.7 * hops_coarse);
  const double spacing = interact::paper_ring_spacing_mm(coarse);
  // The same organ: its skin's area, so the spacing, within the meshes' 2%.
  EXPECT_NEAR(interact::paper_ring_spacing_mm(fine) / spacing, 1.0, 0.02);
  const double mm_coarse = load_radius(coarse, top_node(coarse), spacing);
  const double mm_fine = load_radius(fine, top_node(fine), spacing);
  EXPECT_NEAR(mm_fine / mm_coarse, 1.0, 0.15);
  // "paper" is that spacing, resolved from the model.
  EXPECT_DOUBLE_EQ(load_radius(fine, top_node(fine), interact::kPaperRingSpacing),
                   load_radius(fine, top_node(fine), interact::paper_ring_spacing_mm(fine)));
}

TEST(RingsByDistance, AtTheMeshsOwnEdgeTheyAreCloseToTheHopRings) {
  const Model& m = test::sphere_model();
  const int32_t v = top_node(m);
  // The mean length of the skin's edges at rest.
  double length = 0.0;
  int64_t edges = 0;
  for (int32_t u = 0; u < m.layers[0].node_count; ++u)
    for (int64_t k = 0; k < m.rings.ring_size(u, 1); ++k)
      length += (m.X.row(m.rings.ring(u, 1)[k]) - m.X.row(u)).norm(), ++edges;
  const std::vector<interact::RingMember> rings =
      interact::rings_by_distance(m, v, 3, length / static_cast<double>(edges));
  std::set<int32_t> near, hop_near;
  for (const interact::RingMember& r : rings) {
    EXPECT_EQ(m.layer_of[r.node], 0);  // within the contact's own layer
    EXPECT_GE(r.ring, 0);
    EXPECT_LT(r.ring, 3);
    if (r.ring <= 1) near.insert(r.node);
  }
  for (int32_t r = 0; r <= 1; ++r)
    for (int64_t k = 0; k < m.rings.ring_size(v, r); ++k) hop_near.insert(m.rings.ring(v, r)[k]);
  int32_t shared = 0;
  for (int32_t u : hop_near) shared += near.count(u) ? 1 : 0;
  EXPECT_GE(shared, static_cast<int32_t>(0.8 * static_cast<double>(hop_near.size())));
  EXPECT_LE(near.size(), 2 * hop_near.size());
  // The paper-size spacing is the edge of a 1,284-vertex skin of the same area: a 600-vertex
  // skin's edge times sqrt((2 * 600 - 4) / (2 * 1284 - 4)).
  EXPECT_NEAR(interact::paper_ring_spacing_mm(m) / (length / static_cast<double>(edges)),
              std::sqrt(1196.0 / 2564.0), 0.15 * std::sqrt(1196.0 / 2564.0));
}

TEST(RingsByDistance, ABadSpacingIsNamedByItsKey) {
  const auto key = [](double spacing) {
    const auto p = interact::routing_problem({.ring_spacing_mm = spacing}, 4);
    return p ? p->key : std::string("none");
  };
  EXPECT_EQ(key(0.0), "none");
  EXPECT_EQ(key(2.5), "none");
  EXPECT_EQ(key(interact::kPaperRingSpacing), "none");
  EXPECT_EQ(key(-0.5), "ring_spacing_mm");
  EXPECT_EQ(key(std::nan("")), "ring_spacing_mm");
  EXPECT_EQ(key(std::numeric_limits<double>::infinity()), "ring_spacing_mm");
}

}  // namespace
