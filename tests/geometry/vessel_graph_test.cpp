// A skeleton's graph on shapes whose graph is known: a T of tubes (one junction, three ends,
// the branches' lengths and radii), a torus (one closed loop), a cylinder and a lone voxel.
#include "lamina/geometry/vessel_graph.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "support/volumes.h"

namespace {

using namespace lamina;
using geometry::skeletonize;
using geometry::vessel_graph;
using geometry::VesselGraph;

// Every voxel of the skeleton is in exactly one node or one branch.
void expect_partition(const geometry::Skeleton& s, const VesselGraph& g) {
  std::vector<int64_t> all;
  for (const VesselGraph::Node& n : g.nodes)
    all.insert(all.end(), n.voxels.begin(), n.voxels.end());
  for (const VesselGraph::Branch& b : g.branches)
    all.insert(all.end(), b.voxels.begin(), b.voxels.end());
  std::sort(all.begin(), all.end());
  EXPECT_EQ(all, s.voxels);
  int32_t degrees = 0;
  for (const VesselGraph::Node& n : g.nodes) degrees += n.degree;
  EXPECT_EQ(degrees, 2 * static_cast<int32_t>(g.branches.size()));
}

TEST(VesselGraph, ATOfTubesIsOneJunctionThreeEndsAndThreeBranchesOfTheirLengths) {
  // A trunk along z (6..54 mm) and a branch along x (12..42 mm) from its middle (z = 30), radius
  // 2.5 mm, on 0.6 x 0.6 x 1.5 mm voxels.
  const double r = 2.5;
  const Mask m = test::mask_where({80, 30, 40}, {0.6, 0.6, 1.5}, [&](double x, double y, double z) {
    return (z >= 6 && z <= 54 && std::hypot(x - 12, y - 9) <= r) ||
           (x >= 12 && x <= 42 && std::hypot(y - 9, z - 30) <= r);
  });
  const geometry::Skeleton s = skeletonize(m);
  const VesselGraph g = vessel_graph(s);
  expect_partition(s, g);
  ASSERT_EQ(g.nodes.size(), 4u);
  ASSERT_EQ(g.branches.size(), 3u);
  int ends = 0;
  const VesselGraph::Node* junction = nullptr;
  for (const VesselGraph::Node& n : g.nodes) {
    ends += n.degree == 1;
    if (n.degree == 3) junction = &n;
  }
  EXPECT_EQ(ends, 3);
  ASSERT_NE(junction, nullptr);
  EXPECT_NEAR(junction->position_mm.x(), 12.0, 1.5);
  EXPECT_NEAR(junction->position_mm.z(), 30.0, 2.0);
  // Each branch from the junction to where its tube's axis ends, about a radius short of the cap.
  std::vector<double> lengths;
  for (const VesselGraph::Branch& b : g.branches) {
    lengths.push_back(b.length_mm);
    EXPECT_GT(b.radius_mm, r - 0.5);
    EXPECT_LT(b.radius_mm, r + 1.0);
  }
  std::sort(lengths.begin(), lengths.end());
  EXPECT_NEAR(lengths[0], 24.0 - r, 3.5);  // up and down the trunk
  EXPECT_NEAR(lengths[1], 24.0 - r, 3.5);
  EXPECT_NEAR(lengths[2], 30.0 - r, 3.5);  // the side branch
}

TEST(VesselGraph, ATorusIsOneClosedLoopOfItsCircumference) {
  const double big = 12.0, small = 3.5;
  const Mask m = test::mask_where({41, 41, 21}, {1, 1, 1}, [&](double x, double y, double z) {
    return std::hypot(std::hypot(x - 20, y - 20) - big, z - 10) <= small;
  });
  const geometry::Skeleton s = skeletonize(m);
  const VesselGraph g = vessel_graph(s);
  expect_partition(s, g);
  ASSERT_EQ(g.nodes.size(), 1u);
  ASSERT_EQ(g.branches.size(), 1u);
  EXPECT_EQ(g.branches[0].a, g.branches[0].b);
  EXPECT_EQ(g.nodes[0].degree, 2);
  // A voxel path round the circle is a little longer than it (its steps zigzag).
  EXPECT_GT(g.branches[0].length_mm, 2.0 * std::numbers::pi * big * 0.95);
  EXPECT_LT(g.branches[0].length_mm, 2.0 * std::numbers::pi * big * 1.15);
}

TEST(VesselGraph, ACylinderIsOneBranchAndALoneVoxelOneNode) {
  const Mask tube = test::mask_where({50, 21, 21}, {1, 1, 1}, [](double x, double y, double z) {
    return x >= 5 && x <= 44 && std::hypot(y - 10, z - 10) <= 3.0;
  });
  const geometry::Skeleton s = skeletonize(tube);
  const VesselGraph g = vessel_graph(s);
  expect_partition(s, g);
  ASSERT_EQ(g.nodes.size(), 2u);
  ASSERT_EQ(g.branches.size(), 1u);
  EXPECT_NEAR(g.branches[0].length_mm, 39.0 - 2.0 * 3.0, 3.0);

  const Mask dot = test::mask_where({5, 5, 5}, {1, 1, 1}, [](double x, double y, double z) {
    return x == 2 && y == 2 && z == 2;
  });
  const VesselGraph d = vessel_graph(skeletonize(dot));
  ASSERT_EQ(d.nodes.size(), 1u);
  EXPECT_TRUE(d.branches.empty());
  EXPECT_EQ(d.nodes[0].degree, 0);
  EXPECT_TRUE(vessel_graph(geometry::Skeleton{}).nodes.empty());
}

}  // namespace
