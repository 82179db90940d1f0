// Branch territories on the phantom, whose portal tree is known by construction (make_phantom.cpp,
// kVessels): they partition the organ, each lobe's subtree feeds the volume nearest to its built
// segments within 2%, and each leaf branch's territory is its built segment's within 10%.
#include "lamina/geometry/vessel_territories.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>

#include "lamina/core/error.h"
#include "lamina/geometry/make_phantom.h"

namespace {

using namespace lamina;

struct Segment {
  Eigen::Vector3d a, b;
};

double distance_to(const Eigen::Vector3d& p, const Segment& s) {
  const Eigen::Vector3d ab = s.b - s.a;
  const double t = std::clamp((p - s.a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (p - s.a - t * ab).norm();
}

TEST(BranchTerritories, OnThePhantomTheyPartitionTheOrganAsItsBuiltTreeDoes) {
  geometry::PhantomOptions o;
  o.spacing_mm = {1.0, 1.0, 1.0};
  o.carved_out = true;
  const LabelVolume v = geometry::make_phantom(o);
  Mask vessel, organ;
  vessel.frame = organ.frame = v.frame;
  vessel.inside.resize(v.labels.size());
  organ.inside.resize(v.labels.size());
  for (size_t i = 0; i < v.labels.size(); ++i) {
    vessel.inside[i] = v.labels[i] == geometry::kPhantomVessel ? 1 : 0;
    organ.inside[i] = v.labels[i] != 0 && v.labels[i] != geometry::kPhantomVenaCava ? 1 : 0;
  }
  const geometry::VesselGraph g = geometry::vessel_graph(geometry::skeletonize(vessel));
  const std::vector<int32_t> t = geometry::branch_territories(organ, g);

  // The tree as built: the trunk, the right and left branches, and the four leaves.
  const std::vector<Segment> built{{{-12, 28, -80}, {-14, 14, -22}}, {{-14, 14, -22}, {-55, 8, -8}},
                                   {{-14, 14, -22}, {22, 2, -2}},    {{-55, 8, -8}, {-88, 2, 10}},
                                   {{-55, 8, -8}, {-60, 26, -26}},   {{22, 2, -2}, {62, -14, 14}},
                                   {{22, 2, -2}, {38, 18, 14}}};
  // Per built segment: its volume (the organ's voxels nearest to it) and, per branch, how much
  // of it that branch's territory holds.
  std::vector<int64_t> volume(built.size(), 0);
  std::vector<std::vector<int64_t>> shared(built.size(), std::vector<int64_t>(g.branches.size()));
  std::vector<int64_t> territory(g.branches.size(), 0);
  const GridFrame& f = v.frame;
  for (int64_t k = 0; k < f.size[2]; ++k)
    for (int64_t j = 0; j < f.size[1]; ++j)
      for (int64_t i = 0; i < f.size[0]; ++i) {
        const int64_t x = f.index(i, j, k);
        const int32_t b = t[static_cast<size_t>(x)];
        if (organ.inside[static_cast<size_t>(x)] == 0) {
          ASSERT_EQ(b, -1) << "outside the organ";
          continue;
        }
        ASSERT_GE(b, 0) << "an organ voxel in no territory";
        ASSERT_LT(b, static_cast<int32_t>(g.branches.size()));
        ++territory[static_cast<size_t>(b)];
        const auto p =
            f.to_physical(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k));
        const Eigen::Vector3d point(p[0], p[1], p[2]);
        size_t nearest = 0;
        for (size_t s = 1; s < built.size(); ++s)
          if (distance_to(point, built[s]) < distance_to(point, built[nearest])) nearest = s;
        ++volume[nearest];
        ++shared[nearest][static_cast<size_t>(b)];
      }
  // Each built segment's branch: the one whose territory holds most of it.
  std::vector<size_t> branch(built.size());
  for (size_t s = 0; s < built.size(); ++s)
    branch[s] = static_cast<size_t>(std::max_element(shared[s].begin(), shared[s].end()) -
                                    shared[s].begin());
  std::vector<size_t> sorted = branch;
  std::sort(sorted.begin(), sorted.end());
  EXPECT_EQ(std::unique(sorted.begin(), sorted.end()), sorted.end()) << "one branch a segment";
  const auto subtree = [&](std::initializer_list<size_t> segments) {
    int64_t made = 0, from_built = 0;
    for (const size_t s : segments) {
      made += territory[branch[s]];
      from_built += volume[s];
    }
    return std::pair{static_cast<double>(made), static_cast<double>(from_built)};
  };
  for (const auto& [made, expected] : {subtree({1, 3, 4}), subtree({2, 5, 6})})
    EXPECT_NEAR(made, expected, 0.02 * expected) << "a lobe's subtree";
  for (const size_t s : {3, 4, 5, 6}) {
    EXPECT_NEAR(static_cast<double>(territory[branch[s]]), static_cast<double>(volume[s]),
                0.10 * static_cast<double>(volume[s]))
        << "leaf " << s;
    EXPECT_GT(static_cast<double>(shared[s][branch[s]]), 0.9 * static_cast<double>(volume[s]));
  }
}

TEST(BranchTerritories, AGraphOfAnotherGridIsRefusedAndNoBranchesNoTerritory) {
  Mask organ;
  organ.frame.size = {6, 5, 4};
  organ.inside.assign(120, 1);
  geometry::VesselGraph other;
  other.frame.size = {6, 5, 5};
  other.branches.emplace_back();
  EXPECT_THROW(geometry::branch_territories(organ, other), Error);
  geometry::VesselGraph none;
  none.frame = organ.frame;
  for (const int32_t b : geometry::branch_territories(organ, none)) EXPECT_EQ(b, -1);
}

}  // namespace
