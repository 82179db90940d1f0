// vessel_tree on the phantom's portal vein (built: a trunk from below the hilum, a right and a
// left branch, two leaves each): rooted at the trunk where it leaves the organ, each branch's
// parent the built one, a gap cut into a branch bridged, and a vessel that never reaches the
// organ's surface refused.
#include "lamina/geometry/vessel_tree.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "lamina/core/error.h"
#include "lamina/geometry/make_phantom.h"
#include "lamina/geometry/skeletonize.h"
#include "support/volumes.h"

namespace lamina::geometry {
namespace {

using Phantom = test::OrganAndVessels;

Phantom phantom() {
  return test::phantom_organ_and_vessels({kPhantomVessel});
}

// The branches of `t` in a tree.
int32_t count_rooted(const VesselTree& t) {
  int32_t n = 0;
  for (const int32_t f : t.from_node) n += f >= 0;
  return n;
}

TEST(VesselTree, ThePhantomsPortalTreeIsRootedAtItsTrunkWithItsBuiltParents) {
  const Phantom p = phantom();
  const VesselTree t = vessel_tree(vessel_graph(skeletonize(p.vessels)), p.organ, "portal vein");
  ASSERT_EQ(t.roots.size(), 1u);
  const Eigen::Vector3d root = t.graph.nodes[static_cast<size_t>(t.roots[0])].position_mm;
  EXPECT_LT(root.z(), -50.0) << "the trunk's lower end, below the hilum";
  EXPECT_EQ(t.bridged_gaps, 0);
  EXPECT_EQ(t.unrooted_mm, 0.0);
  ASSERT_EQ(t.graph.branches.size(), 7u);
  EXPECT_EQ(count_rooted(t), 7);
  // The trunk leaves the root; the right and left branches its children; the leaves theirs.
  int32_t trunk = -1;
  for (size_t b = 0; b < 7; ++b)
    if (t.parent[b] < 0) {
      EXPECT_EQ(trunk, -1) << "one branch leaves the root";
      trunk = static_cast<int32_t>(b);
    }
  ASSERT_GE(trunk, 0);
  std::vector<int32_t> children(7, 0);
  for (size_t b = 0; b < 7; ++b)
    if (t.parent[b] >= 0) ++children[static_cast<size_t>(t.parent[b])];
  EXPECT_EQ(children[static_cast<size_t>(trunk)], 2);
  int32_t with_two = 0, leaves = 0;
  for (size_t b = 0; b < 7; ++b) {
    with_two += children[b] == 2;
    leaves += children[b] == 0;
  }
  EXPECT_EQ(with_two, 3);
  EXPECT_EQ(leaves, 4);
  // Order: each branch after its parent.
  std::vector<int32_t> seen(7, 0);
  for (const int32_t b : t.order) {
    if (t.parent[static_cast<size_t>(b)] >= 0) EXPECT_TRUE(seen[static_cast<size_t>(t.parent[b])]);
    seen[static_cast<size_t>(b)] = 1;
  }
}

TEST(VesselTree, AGapCutIntoABranchIsBridged) {
  Phantom p = phantom();
  // A 3 mm slab across the left branch (x from -14 to 22) at x = 5.
  const GridFrame& f = p.vessels.frame;
  for (int64_t k = 0; k < f.size[2]; ++k)
    for (int64_t j = 0; j < f.size[1]; ++j)
      for (int64_t i = 0; i < f.size[0]; ++i) {
        const auto x =
            f.to_physical(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k));
        if (x[0] > 3.5 && x[0] < 6.5) p.vessels.inside[static_cast<size_t>(f.index(i, j, k))] = 0;
      }
  const VesselTree t = vessel_tree(vessel_graph(skeletonize(p.vessels)), p.organ, "portal vein");
  EXPECT_EQ(t.roots.size(), 1u);
  EXPECT_GE(t.bridged_gaps, 1);
  EXPECT_EQ(t.unrooted_mm, 0.0) << "the left lobe's part reached through the bridge";
  EXPECT_EQ(count_rooted(t), static_cast<int32_t>(t.graph.branches.size()));
}

TEST(VesselTree, AVesselThatNeverReachesTheOrgansSurfaceHasNoRoot) {
  // A tube inside a block, 10 voxels clear of its faces.
  Mask organ, vessel;
  organ.frame.size = vessel.frame.size = {40, 30, 30};
  organ.inside.assign(36000, 1);
  vessel.inside.assign(36000, 0);
  for (int64_t i = 10; i < 30; ++i)
    for (int64_t j = 14; j < 17; ++j)
      for (int64_t k = 14; k < 17; ++k)
        vessel.inside[static_cast<size_t>(vessel.frame.index(i, j, k))] = 1;
  try {
    vessel_tree(vessel_graph(skeletonize(vessel)), organ, "hepatic veins");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("hepatic veins"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no root"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace lamina::geometry

namespace lamina::geometry {
namespace {

// The least distance from p to a voxel centre of `mask`, mm.
double distance_to(const Mask& mask, const Eigen::Vector3d& p) {
  double best = INFINITY;
  const GridFrame& f = mask.frame;
  for (int64_t k = 0; k < f.size[2]; ++k)
    for (int64_t j = 0; j < f.size[1]; ++j)
      for (int64_t i = 0; i < f.size[0]; ++i) {
        if (mask.inside[static_cast<size_t>(f.index(i, j, k))] == 0) continue;
        const auto q =
            f.to_physical(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k));
        best = std::min(best, (p - Eigen::Vector3d(q[0], q[1], q[2])).norm());
      }
  return best;
}

TEST(VesselTree, GivenTheVenaCavaTheHepaticVeinsAreRootedWhereTheyDrainIntoIt) {
  // The wrapped phantom: the liver closes behind the vena cava, and the right hepatic vein
  // reaches the organ's lateral surface, here widened there (as a real segmentation's blobs can).
  // Rooted at the organ's outside, the tree starts at its widest end there; given the vena cava
  // (issue 63), at the vena cava.
  PhantomOptions o;
  o.spacing_mm = {1.5, 1.5, 1.5};
  o.carved_out = true;
  o.wrapped = true;
  const LabelVolume v = make_phantom(o);
  Mask organ, veins, cava;
  organ.frame = veins.frame = cava.frame = v.frame;
  for (const int32_t l : v.labels) {
    organ.inside.push_back(l != 0 && l != kPhantomVenaCava ? 1 : 0);
    veins.inside.push_back(l == kPhantomHepaticVeins ? 1 : 0);
    cava.inside.push_back(l == kPhantomVenaCava ? 1 : 0);
  }
  // The right vein widened (7 mm) for 25 mm from where it reaches the lateral surface (its end
  // of least x, the patient's right): rooted at the organ's outside, the tree starts there.
  {
    const VesselGraph first = vessel_graph(skeletonize(veins));
    Eigen::Vector3d lateral(INFINITY, 0, 0);
    for (const auto& n : first.nodes)
      if (n.position_mm.x() < lateral.x()) lateral = n.position_mm;
    const GridFrame& f = v.frame;
    for (int64_t k = 0; k < f.size[2]; ++k)
      for (int64_t j = 0; j < f.size[1]; ++j)
        for (int64_t i = 0; i < f.size[0]; ++i) {
          const auto q =
              f.to_physical(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k));
          const Eigen::Vector3d d = Eigen::Vector3d(q[0], q[1], q[2]) - lateral;
          const double t = std::clamp(d.x(), 0.0, 25.0);  // along +x, 25 mm in
          if ((d - Eigen::Vector3d(t, 0, 0)).norm() <= 7.0)
            veins.inside[static_cast<size_t>(f.index(i, j, k))] = 1;
        }
  }
  const VesselGraph g = vessel_graph(skeletonize(veins));
  VesselTreeOptions at_cava;
  at_cava.outlet = &cava;
  const VesselTree with = vessel_tree(g, organ, "hepatic veins", at_cava);
  const VesselTree without = vessel_tree(g, organ, "hepatic veins");
  ASSERT_FALSE(with.roots.empty());
  EXPECT_GE(with.outlet_roots, 1);
  EXPECT_LE(with.outlet_roots, static_cast<int32_t>(with.roots.size()))
      << "counted among the kept roots";
  EXPECT_EQ(without.outlet_roots, 0);
  const auto root_distance = [&](const VesselTree& t) {
    double d = INFINITY;
    for (const int32_t r : t.roots)
      d = std::min(d, distance_to(cava, t.graph.nodes[static_cast<size_t>(r)].position_mm));
    return d;
  };
  const double d_with = root_distance(with), d_without = root_distance(without);
  // Within the widest vein's radius and two voxels of the vena cava; without it, at the blob.
  EXPECT_LT(d_with, 10.0) << "without the vena cava the root is " << d_without << " mm from it";
  EXPECT_GT(d_without, 50.0);
}

}  // namespace
}  // namespace lamina::geometry
