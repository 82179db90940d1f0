// vessel_tree on the phantom's portal vein (built: a trunk from below the hilum, a right and a
// left branch, two leaves each): rooted at the trunk where it leaves the organ, each branch's
// parent the built one, a gap cut into a branch bridged, and a vessel that never reaches the
// organ's surface refused.
#include "lamina/geometry/vessel_tree.h"

#include <gtest/gtest.h>

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
