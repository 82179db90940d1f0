#include "lamina/geometry/enclosed_structures.h"

#include <gtest/gtest.h>

#include <cmath>

#include "lamina/core/grid.h"

namespace {

using namespace lamina;

// A 40^3 grid with an organ cube [10, 30)^3 (label buffer `organ`) and structures painted by
// the tests (buffer `structures`, value = structure index + 1), carved out of the organ.
struct Scene {
  GridFrame f;
  std::vector<uint8_t> organ, structures;
  std::vector<uint8_t> whole;  ///< per structure: taken whole (a tumour)
  Scene() {
    f.size = {40, 40, 40};
    f.spacing_mm = {1.0, 1.0, 1.0};
    organ.assign(static_cast<size_t>(f.voxel_count()), 0);
    structures = organ;
    for (int64_t k = 10; k < 30; ++k)
      for (int64_t j = 10; j < 30; ++j)
        for (int64_t i = 10; i < 30; ++i) organ[static_cast<size_t>(f.index(i, j, k))] = 1;
  }
  // Carves structure s (1-based) out of the organ where `in(i, j, k)` holds.
  template <class In>
  void carve(uint8_t s, In&& in) {
    for (int64_t k = 0; k < 40; ++k)
      for (int64_t j = 0; j < 40; ++j)
        for (int64_t i = 0; i < 40; ++i)
          if (in(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k))) {
            const size_t v = static_cast<size_t>(f.index(i, j, k));
            organ[v] = 0;
            structures[v] = s;
          }
  }
  geometry::EnclosedCounts run(int32_t count) {
    return geometry::add_enclosed_structures(f, organ, structures, count, whole, {10, 10, 10},
                                             {29, 29, 29});
  }
  bool is_organ(int64_t i, int64_t j, int64_t k) const {
    return organ[static_cast<size_t>(f.index(i, j, k))] != 0;
  }
  // Whether the organ is exactly the cube again.
  int64_t differences_from_cube() const {
    int64_t n = 0;
    for (int64_t k = 0; k < 40; ++k)
      for (int64_t j = 0; j < 40; ++j)
        for (int64_t i = 0; i < 40; ++i) {
          const bool cube = i >= 10 && i < 30 && j >= 10 && j < 30 && k >= 10 && k < 30;
          n += cube != is_organ(i, j, k);
        }
    return n;
  }
};

TEST(EnclosedStructures, AVesselTunnelOpenAtTheSurfaceIsTakenInUpToTheOrgansOutline) {
  // A vessel from outside the organ (below it, k < 10) up into its middle, where it ends: its
  // tunnel through the organ's label opens on the lower face.
  Scene s;
  s.carve(1, [](double i, double j, double k) {
    return std::hypot(i - 20, j - 20) <= 3.0 && k >= 2 && k <= 20;
  });
  const geometry::EnclosedCounts c = s.run(1);
  // Inside the cube every vessel voxel is now organ, the mouth of the tunnel too; the trunk
  // below the organ is not (nothing closes the lines along the face through it).
  EXPECT_EQ(s.differences_from_cube(), 0);
  ASSERT_EQ(c.voxels.size(), 1u);
  int64_t in_cube = 0, below = 0;
  for (int64_t k = 2; k <= 20; ++k)
    for (int64_t j = 0; j < 40; ++j)
      for (int64_t i = 0; i < 40; ++i)
        if (std::hypot(i - 20.0, j - 20.0) <= 3.0) (k >= 10 ? in_cube : below)++;
  EXPECT_EQ(c.voxels[0], in_cube + below);
  EXPECT_EQ(c.inside[0], in_cube);
  EXPECT_EQ(c.added, in_cube);
  // The trunk's voxels within 3 voxels of the organ (k = 7, 8, 9) are beside it.
  EXPECT_EQ(c.beside[0], 3 * (below / 8));
  EXPECT_EQ(c.organ_own, 20 * 20 * 20 - in_cube);
}

TEST(EnclosedStructures, ATumourAtTheSurfaceFillsItsCraterButNotItsBulge) {
  // A sphere centred on the upper face (k = 29.5): half in the organ, half bulging out.
  Scene s;
  s.carve(1,
          [](double i, double j, double k) { return std::hypot(i - 20, j - 20, k - 29.5) <= 6.0; });
  s.run(1);
  EXPECT_EQ(s.differences_from_cube(), 0);
}

TEST(EnclosedStructures, AVesselThroughTheWholeOrganIsTakenInButNotItsTrunks) {
  // A vessel crossing the organ in a straight line from face to face and running on beyond both
  // (a hepatic vein into the vena cava, a vena cava the caudate lobe wraps): the line along it is
  // open both ways, yet every ray across it meets the organ. Along an axis and along a diagonal.
  for (const bool diagonal : {false, true}) {
    SCOPED_TRACE(diagonal ? "diagonal" : "along k");
    Scene s;
    s.carve(1, [&](double i, double j, double k) {
      if (!diagonal) return std::hypot(i - 20, j - 20) <= 3.5;  // k from 0 to 39
      // Along (1, 0.5, 0.25) through the cube's centre, leaving it through the middle of two
      // opposite faces (x = 10 and 30, at y = 15 and 25): distance from the line.
      const double u = i - 20, v = j - 20, w = k - 20;
      const double t = (u + 0.5 * v + 0.25 * w) / (1.0 + 0.25 + 0.0625);
      return std::hypot(u - t, v - 0.5 * t, w - 0.25 * t) <= 3.5;
    });
    const geometry::EnclosedCounts c = s.run(1);
    EXPECT_EQ(s.differences_from_cube(), 0);
    // Along an axis the line along the tunnel runs out both ways: the ray rule takes it in (at
    // an angle to every one of the 13 lines, the line rule does).
    if (!diagonal) EXPECT_GT(c.by_rays, 0) << "the line rule alone leaves the tunnel open";
    EXPECT_LT(c.inside[0], c.voxels[0]);  // the trunks beyond the faces stay out
  }
}

TEST(EnclosedStructures, ATumourTakenWholeKeepsItsBulge) {
  // The same tumour as above, as a tumour (a lesion is the organ's tissue): all of it is organ,
  // its bulge through the capsule too; one away from the organ is not.
  Scene s;
  s.carve(1,
          [](double i, double j, double k) { return std::hypot(i - 20, j - 20, k - 29.5) <= 6.0; });
  s.carve(2, [](double i, double j, double k) { return std::hypot(i - 3, j - 3, k - 3) <= 2; });
  s.whole = {1, 1};
  const geometry::EnclosedCounts c = s.run(2);
  EXPECT_EQ(c.inside[0], c.voxels[0]);
  EXPECT_GT(c.by_whole, 0);
  EXPECT_EQ(c.inside[1], 0);
  EXPECT_TRUE(s.is_organ(20, 20, 33));  // above the upper face, in the bulge
}

TEST(EnclosedStructures, AVeinInAGrooveAlongTheOrganIsNotTakenIn) {
  // A vessel along the whole length of the organ's back (j = 29.5), half in it, running on
  // beyond both ends: a groove, open along the vessel.
  Scene s;
  s.carve(1, [](double i, double j, double k) {
    (void)k;
    return std::hypot(i - 20, j - 29.5) <= 4.0;
  });
  const std::vector<uint8_t> before = s.organ;
  const geometry::EnclosedCounts c = s.run(1);
  EXPECT_EQ(c.added, 0);
  EXPECT_EQ(s.organ, before);
  EXPECT_GT(c.beside[0], 0);
}

TEST(EnclosedStructures, AStructureAwayFromTheOrganIsNeitherInsideNorBeside) {
  Scene s;
  s.carve(1, [](double i, double j, double k) { return std::hypot(i - 20, j - 20, k - 20) <= 4; });
  s.carve(2, [](double i, double j, double k) { return std::hypot(i - 3, j - 3, k - 3) <= 2; });
  const geometry::EnclosedCounts c = s.run(2);
  EXPECT_EQ(c.inside[0], c.voxels[0]);  // enclosed on every side: all of it
  EXPECT_GT(c.voxels[1], 0);
  EXPECT_EQ(c.inside[1], 0);
  EXPECT_EQ(c.beside[1], 0);
  EXPECT_EQ(s.differences_from_cube(), 0);
}

TEST(EnclosedStructures, AnOverlappingMaskStaysOrganAndCountsAsInside) {
  // A separate mask drawn over the organ (the union layout): its voxels are organ already.
  Scene s;
  for (int64_t k = 15; k < 18; ++k)
    for (int64_t j = 15; j < 18; ++j)
      for (int64_t i = 15; i < 18; ++i) s.structures[static_cast<size_t>(s.f.index(i, j, k))] = 1;
  const geometry::EnclosedCounts c = s.run(1);
  EXPECT_EQ(c.voxels[0], 27);
  EXPECT_EQ(c.inside[0], 27);
  EXPECT_EQ(c.added, 0);
  EXPECT_EQ(c.organ_own, 20 * 20 * 20 - 27);
}

}  // namespace
