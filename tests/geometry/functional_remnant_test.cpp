// The functional remnant on the planning phantom, whose portal tree is known by construction
// (make_phantom.cpp, kVessels): the territories partition the organ, and a plane that divides the
// left portal branch devascularizes the remnant's tissue nearest the built tree downstream of
// the cut, within 2%.
#include "lamina/geometry/functional_remnant.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>

#include "lamina/core/error.h"
#include "lamina/geometry/make_phantom.h"
#include "lamina/geometry/plan_resection.h"
#include "lamina/io/label_volume_io.h"
#include "support/test_paths.h"

namespace lamina::geometry {
namespace {

struct Segment {
  Eigen::Vector3d a, b;
};

// The built portal tree: the trunk, the right and left branches, the four leaves.
const std::vector<Segment> kBuilt{{{-12, 28, -80}, {-14, 14, -22}}, {{-14, 14, -22}, {-55, 8, -8}},
                                  {{-14, 14, -22}, {22, 2, -2}},    {{-55, 8, -8}, {-88, 2, 10}},
                                  {{-55, 8, -8}, {-60, 26, -26}},   {{22, 2, -2}, {62, -14, 14}},
                                  {{22, 2, -2}, {38, 18, 14}}};

Eigen::Vector3d nearest_on(const Eigen::Vector3d& p, const Segment& s) {
  const Eigen::Vector3d ab = s.b - s.a;
  const double t = std::clamp((p - s.a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return s.a + t * ab;
}

// A closed box from x0 to x1 across the whole organ, its triangles facing out: the resection
// takes the slab inside it.
ResectionSurface slab(double x0, double x1) {
  Eigen::MatrixX3d V(8, 3);
  for (int c = 0; c < 8; ++c)
    V.row(c) << ((c & 1) ? x1 : x0), ((c & 2) ? 300.0 : -300.0), ((c & 4) ? 300.0 : -300.0);
  Eigen::MatrixX3i F(12, 3);
  F << 0, 2, 1, 1, 2, 3,  // z low, facing -z
      4, 5, 6, 5, 7, 6,   // z high
      0, 1, 4, 1, 5, 4,   // y low
      2, 6, 3, 3, 6, 7,   // y high
      0, 4, 2, 2, 4, 6,   // x low
      1, 3, 5, 3, 7, 5;   // x high
  return mesh_surface(V, F, "slab");
}

TEST(FunctionalRemnant, DividingTheLeftPortalBranchDevascularizesWhatItFeedsAsBuilt) {
  const LabelVolume v = planning_phantom();
  // A slab from x = 0 to 8 mm taken out of the organ divides the left branch (x from -14 to
  // 22): the left lobe stays, cut off from the trunk. A plane could not keep tissue downstream
  // of the branch it divides.
  const ResectionOptions o = planning_phantom_options();
  const ResectionPlan plan = plan_resection(v, SideOf(slab(0.0, 8.0)), o);
  ASSERT_TRUE(plan.report.remnant_in_front);
  ASSERT_TRUE(plan.report.functional.has_value());
  const FunctionalRemnant& fr = *plan.report.functional;
  EXPECT_TRUE(fr.portal);
  EXPECT_TRUE(fr.hepatic);

  // From the construction: the remnant voxels whose nearest point of the built tree lies
  // beyond the cut (on the left branch past x = 0, or on its leaves).
  const GridFrame& f = v.frame;
  int64_t expected = 0, made = 0;
  for (int64_t k = 0; k < f.size[2]; ++k)
    for (int64_t j = 0; j < f.size[1]; ++j)
      for (int64_t i = 0; i < f.size[0]; ++i) {
        const auto x = static_cast<size_t>(f.index(i, j, k));
        if (plan.parts.labels[x] != 1) continue;
        const uint8_t fn = static_cast<uint8_t>(plan.function.labels[x]);
        ASSERT_NE(fn, 0) << "a remnant voxel without its function";
        made += fn == kDevascularized || fn == kDevascularizedCongested;
        const auto p =
            f.to_physical(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k));
        const Eigen::Vector3d point(p[0], p[1], p[2]);
        size_t best = 0;
        Eigen::Vector3d at = nearest_on(point, kBuilt[0]);
        for (size_t s = 1; s < kBuilt.size(); ++s) {
          const Eigen::Vector3d q = nearest_on(point, kBuilt[s]);
          if ((q - point).norm() < (at - point).norm()) best = s, at = q;
        }
        expected += (best == 2 && at.x() > 0.0) || best == 5 || best == 6;
      }
  ASSERT_GT(expected, 1000);
  EXPECT_NEAR(static_cast<double>(made), static_cast<double>(expected),
              0.02 * static_cast<double>(expected));
  // The lost volumes are the remnant's share of its voxels by centre.
  EXPECT_NEAR(fr.devascularized_ml,
              plan.report.remnant_ml * static_cast<double>(made) /
                  static_cast<double>(plan.report.remnant_voxels),
              1e-9);

  // Each tree's territories partition the organ: their volumes sum to the whole's.
  for (const TreeFate& t : fr.trees) {
    double sum = 0.0;
    for (const BranchFate& b : t.branches) sum += b.territory_ml;
    EXPECT_NEAR(sum, plan.report.whole_ml, 0.001 * plan.report.whole_ml) << t.name;
  }
  // The portal tree: the left branch divided, the rest kept or cut off.
  const TreeFate& portal = fr.trees[0];
  EXPECT_EQ(portal.divided, 1);
  int32_t cut_off = 0;
  for (const BranchFate& b : portal.branches) cut_off += b.state == "cut off";
  EXPECT_EQ(cut_off, 2) << "the left lobe's two leaves";
  EXPECT_NEAR(fr.functional_ml, plan.report.remnant_ml - fr.lost_ml, 1e-9);
  EXPECT_LT(plan.report.functional_flr_percent, plan.report.flr_percent);
}

TEST(FunctionalRemnant, APlaneThatMissesTheTreesCutsNothingOff) {
  // Through the left lobe's tip, beyond every vessel.
  ResectionOptions o = planning_phantom_options();
  const ResectionPlan plan =
      plan_resection(planning_phantom(), SideOf(plane_surface({95, 0, 0}, {1, 0, 0})), o);
  ASSERT_TRUE(plan.report.functional.has_value());
  EXPECT_EQ(plan.report.functional->lost_ml, 0.0);
  EXPECT_NEAR(plan.report.functional->functional_ml, plan.report.remnant_ml, 1e-9);
  for (const TreeFate& t : plan.report.functional->trees) EXPECT_EQ(t.divided, 0) << t.name;
}

TEST(FunctionalRemnant, EachTumoursPortalTerritoryIsTheBranchBuiltToFeedIt) {
  // The right lobe's tumour at (-60, -18, 32) lies nearest the right lateral leaf, built from
  // (-55, 8, -8) to (-88, 2, 10); the left lobe's lesion at (60, -14, 43.5) the left lateral
  // one, (22, 2, -2) to (62, -14, 14).
  const ResectionPlan plan = plan_resection(
      planning_phantom(), SideOf(plane_surface({5, 0, 0}, {1, 0, 0})), planning_phantom_options());
  ASSERT_EQ(plan.report.tumours.size(), 2u);
  const VesselTree& tree = plan.trees[0].territories.tree;
  const Eigen::Vector3d leaf_end[2] = {{-88, 2, 10}, {62, -14, 14}};
  for (size_t t = 0; t < 2; ++t) {
    const TumourMargin& tm = plan.report.tumours[t];
    ASSERT_TRUE(tm.territory.has_value());
    const TumourTerritory& tt = *tm.territory;
    ASSERT_EQ(tt.branches.size(), 1u) << tm.name << " " << tm.piece;
    EXPECT_EQ(tt.subtree, tt.branches[0]);
    const VesselGraph::Branch& b = tree.graph.branches[static_cast<size_t>(tt.subtree)];
    const double to_end =
        std::min((tree.graph.nodes[static_cast<size_t>(b.a)].position_mm - leaf_end[t]).norm(),
                 (tree.graph.nodes[static_cast<size_t>(b.b)].position_mm - leaf_end[t]).norm());
    EXPECT_LT(to_end, 8.0) << "the built leaf's end (its skeleton ends a radius or so short)";
    const auto& fate = plan.report.functional->trees[0].branches[static_cast<size_t>(tt.subtree)];
    EXPECT_NEAR(tt.territory_ml, fate.territory_ml, 1e-9);
  }
}

TEST(FunctionalRemnant, OnARealSegmentationTheLeftBranchIsCutOffOnlyByAPlaneAcrossIt) {
  // TotalSegmentator's example (3 mm): liver, portal and splenic vein, vena cava, gallbladder.
  // The portal vein enters at the hilum near x = -60 mm; its right branch runs to -x, its left
  // one to +x. Sagittal planes, the patient's right side kept.
  const LabelVolume v =
      io::read_label_volume(test::real_data("liver_totalseg_example_3mm_labels.nii.gz"));
  ResectionOptions o;
  o.organ_labels = {1};
  o.structures = {{2, "portal_vein", SurfaceRole::kVessel},
                  {3, "vena_cava", SurfaceRole::kVessel},
                  {4, "gallbladder", SurfaceRole::kStructure}};
  const auto plan_at = [&](double x, double keep_x) {
    o.keep_point = Eigen::Vector3d(keep_x, -185, 389);
    return plan_resection(v, SideOf(plane_surface({x, -185, 389}, {1, 0, 0})), o).report;
  };
  // Across the left lobe, left of the hilum, the right side kept: the left branch divided, the
  // left lobe's tissue right of the plane cut off, the rest kept.
  const ResectionReport across = plan_at(-40.0, -140.0);
  ASSERT_TRUE(across.functional.has_value());
  EXPECT_EQ(across.functional->trees[0].divided, 1);
  EXPECT_GT(across.functional->devascularized_ml, 10.0);
  EXPECT_LT(across.functional->devascularized_ml, 0.5 * across.remnant_ml);
  EXPECT_LT(across.functional_flr_percent, across.flr_percent);
  // Through the right lobe, the hilum's side kept: what the right branch feeds beyond the plane
  // is resected; the remnant keeps its inflow whole.
  const ResectionReport right = plan_at(-100.0, 0.0);
  EXPECT_EQ(right.functional->lost_ml, 0.0);
  EXPECT_DOUBLE_EQ(right.functional_flr_percent, right.flr_percent);
  // The same plane, the right lobe's end kept: it has lost its inflow.
  const ResectionReport end = plan_at(-100.0, -140.0);
  EXPECT_GT(end.functional->devascularized_ml, 0.9 * end.remnant_ml);
}

TEST(FunctionalRemnant, WithoutAPortalVeinOrHepaticVeinsItIsNotClaimed) {
  ResectionOptions o = planning_phantom_options();
  std::erase_if(o.structures, [](const ResectionStructure& s) {
    return vessel_tree_kind(s.name) != VesselTreeKind::kNone;
  });
  const ResectionPlan plan =
      plan_resection(planning_phantom(), SideOf(plane_surface({5, 0, 0}, {1, 0, 0})), o);
  EXPECT_FALSE(plan.report.functional.has_value());
  EXPECT_NE(plan.report.functional_missing.find("no portal vein or hepatic veins"),
            std::string::npos);
}

TEST(FunctionalRemnant, AVesselLabelOutsideTheOrganIsRefusedNamingIt) {
  // The vena cava runs in a groove outside the organ: named as a portal vein, it has no voxel
  // inside it.
  ResectionOptions o = planning_phantom_options();
  for (ResectionStructure& s : o.structures)
    if (s.label == kPhantomVenaCava) s.name = "portal vein (mislabelled)";
  std::erase_if(o.structures,
                [](const ResectionStructure& s) { return s.label == kPhantomVessel; });
  try {
    plan_resection(planning_phantom(), SideOf(plane_surface({5, 0, 0}, {1, 0, 0})), o);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("portal vein (mislabelled)"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("inside the organ"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace lamina::geometry
