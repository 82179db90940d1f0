// A skeleton's graph on shapes whose graph is known: a T of tubes (one junction, three ends,
// the branches' lengths and radii), a torus (one closed loop), a cylinder and a lone voxel.
#include "lamina/geometry/vessel_graph.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "lamina/geometry/make_phantom.h"
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

// The phantom's portal tree, whose segments make_phantom.cpp lists (kVessels, mm): a trunk
// through the hilum to a bifurcation, a branch into each lobe, each dividing in two. Its graph on
// a 1 mm grid is that tree: the three bifurcations and four leaves where they were built, each
// branch as long as its segment within 6% (and a radius, to a leaf) and as wide within 1 mm.
TEST(VesselGraph, ThePhantomsPortalTreeIsTheTreeItWasBuiltAs) {
  geometry::PhantomOptions o;
  o.spacing_mm = {1.0, 1.0, 1.0};
  o.carved_out = true;
  const LabelVolume v = geometry::make_phantom(o);
  Mask m;
  m.frame = v.frame;
  m.inside.resize(v.labels.size());
  for (size_t i = 0; i < v.labels.size(); ++i)
    m.inside[i] = v.labels[i] == geometry::kPhantomVessel ? 1 : 0;
  const VesselGraph g = vessel_graph(skeletonize(m));

  const Eigen::Vector3d hilum(-14, 14, -22), right(-55, 8, -8), left(22, 2, -2);
  const std::vector<Eigen::Vector3d> leaves{
      {-88, 2, 10}, {-60, 26, -26}, {62, -14, 14}, {38, 18, 14}};
  const auto node_near = [&](const Eigen::Vector3d& p, double within_mm) {
    for (size_t n = 0; n < g.nodes.size(); ++n)
      if ((g.nodes[n].position_mm - p).norm() <= within_mm) return static_cast<int32_t>(n);
    return -1;
  };
  ASSERT_EQ(g.branches.size(), 7u);
  ASSERT_EQ(g.nodes.size(), 8u);  // the four leaves, the three bifurcations, the trunk's end
  for (const Eigen::Vector3d& j : {hilum, right, left}) {
    const int32_t n = node_near(j, 2.5);
    ASSERT_GE(n, 0) << "no junction at " << j.transpose();
    EXPECT_EQ(g.nodes[static_cast<size_t>(n)].degree, 3);
  }
  for (const Eigen::Vector3d& leaf : leaves) {
    const int32_t n = node_near(leaf, 3.0);
    ASSERT_GE(n, 0) << "no end at " << leaf.transpose();
    EXPECT_EQ(g.nodes[static_cast<size_t>(n)].degree, 1);
  }
  const auto expect_branch = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                 double radius_mm, bool leaf) {
    const int32_t na = node_near(a, 3.0), nb = node_near(b, 3.0);
    for (const VesselGraph::Branch& br : g.branches)
      if ((br.a == na && br.b == nb) || (br.a == nb && br.b == na)) {
        // A skeleton's free end lies up to a radius inside its tube's rounded end.
        const double slack = 0.06 * (a - b).norm() + (leaf ? radius_mm : 0.0);
        EXPECT_NEAR(br.length_mm, (a - b).norm(), slack) << a.transpose();
        EXPECT_NEAR(br.radius_mm, radius_mm, 1.0);
        return;
      }
    ADD_FAILURE() << "no branch from " << a.transpose() << " to " << b.transpose();
  };
  expect_branch(hilum, right, 4.5, false);
  expect_branch(hilum, left, 4.5, false);
  expect_branch(right, leaves[0], 3.0, true);
  expect_branch(right, leaves[1], 3.0, true);
  expect_branch(left, leaves[2], 3.0, true);
  expect_branch(left, leaves[3], 3.0, true);
}

}  // namespace
