// plan_on_model against plan_resection on the segmentation the model was built from: the same
// plan from the model's own surfaces (display skin, structures), and on a deformed shape.
#include "lamina/model/plan_on_model.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <memory>
#include <random>

#include "lamina/core/error.h"
#include "lamina/geometry/make_phantom.h"
#include "lamina/geometry/volume_by_plane.h"
#include "lamina/model/build_model.h"
#include "lamina/model/cut_tetrahedra.h"
#include "lamina/model/embed_surface.h"
#include "lamina/model/keep_piece.h"
#include "lamina/model/model_territories.h"

namespace lamina::model {
namespace {

// The planning phantom built with its structures from its labels, or (issue 61) from separate
// masks beside the organ's own label as a mask: the same anatomy however it was loaded.
struct Built {
  LabelVolume volume = geometry::planning_phantom();
  Model model;
  explicit Built(bool from_masks = false) {
    BuildOptions o;
    o.display_triangles = 40000;
    o.structure_triangles = 8000;
    LabelVolume organ = volume;
    if (from_masks)
      for (int32_t& l : organ.labels) l = l == geometry::kPhantomLiver ? 1 : 0;
    else
      o.label = geometry::kPhantomLiver;
    for (const auto& s : geometry::planning_phantom_options().structures) {
      if (s.name == "vena_cava") continue;
      if (!from_masks) {
        o.embed.push_back({.name = s.name, .label = s.label});
        continue;
      }
      auto mask = std::make_shared<LabelVolume>(volume);
      for (int32_t& l : mask->labels) l = l == s.label ? 1 : 0;
      mask->source = s.name + ".nii.gz";
      o.embed.push_back({.name = s.name, .mask = mask});
    }
    model = build_model(organ, o).model;
  }
};

const Built& built() {
  static const Built b;
  return b;
}

const Built& built_from_masks() {
  static const Built b(true);
  return b;
}

// The model cut through along the plane x = x0 (a blade wider than the organ).
Model cut_along_x(const Model& m, double x0, CutReport& report) {
  Blade blade;
  geometry::surface_triangles(geometry::plane_surface({x0, 0, 0}, {1, 0, 0}), {x0, 0, 0}, 600.0,
                              blade.V, blade.F);
  Model cut;
  std::vector<int32_t> origin;
  cut_tetrahedra(m, m.X, blade, cut, origin, report);
  EXPECT_EQ(report.pieces.size(), 2u);
  return cut;
}

TEST(SurfaceVolumeByPlane, TheSkinSplitsAsTheTetrahedraThatFillIt) {
  // The tetrahedra fill the skin exactly: its parts on each side of any plane are theirs.
  const Model& m = built().model;
  std::mt19937 rng(7);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d n(g(rng), g(rng), g(rng)),
        p = 30.0 * Eigen::Vector3d(g(rng), g(rng), g(rng));
    const auto a = geometry::surface_volume_by_plane(m.X, m.layers[0].F, p, n);
    const auto b = geometry::volume_by_plane(m.X, m.tets.T, p, n);
    const double whole = b.front_mm3 + b.back_mm3;
    EXPECT_NEAR(a.front_mm3, b.front_mm3, 1e-9 * whole);
    EXPECT_NEAR(a.back_mm3, b.back_mm3, 1e-9 * whole);
  }
}

TEST(PlanOnModel, GivesTheSegmentationsPlanFromItsOwnSurfaces) {
  const Built& b = built();
  const double diag = 1.5 * std::sqrt(3.0);
  for (const double x0 : {-30.0, 30.0}) {
    const auto plane = geometry::plane_surface({x0, 0, 0}, {1, 0, 0});
    geometry::ResectionOptions o = geometry::planning_phantom_options();
    o.structures.pop_back();  // the vena cava, not embedded
    const auto voxels = geometry::plan_resection(b.volume, geometry::SideOf(plane), o).report;
    const auto surfaces = plan_on_model(b.model, b.model.X, plane, o);
    // The display skin encloses the mask's volume within 1%.
    EXPECT_NEAR(surfaces.remnant_ml, voxels.remnant_ml, 0.01 * voxels.remnant_ml) << x0;
    EXPECT_NEAR(surfaces.resected_ml, voxels.resected_ml, 0.01 * voxels.resected_ml) << x0;
    EXPECT_EQ(surfaces.remnant_in_front, voxels.remnant_in_front);
    ASSERT_EQ(surfaces.tumours.size(), voxels.tumours.size());
    for (size_t t = 0; t < voxels.tumours.size(); ++t) {
      EXPECT_EQ(surfaces.tumours[t].side, voxels.tumours[t].side) << x0;
      EXPECT_NEAR(surfaces.tumours[t].margin_mm, voxels.tumours[t].margin_mm, diag) << x0;
    }
    ASSERT_EQ(surfaces.crossings.size(), voxels.crossings.size()) << x0;
    for (const auto& c : voxels.crossings) {
      int found = 0;
      for (const auto& s : surfaces.crossings)
        if (s.name == c.name && (s.position_mm - c.position_mm).norm() < 2.0 * diag) {
          ++found;
          EXPECT_NEAR(s.diameter_mm, c.diameter_mm, diag) << c.name;
        }
      EXPECT_EQ(found, 1) << c.name << " at " << c.position_mm.transpose();
    }
    EXPECT_EQ(surfaces.remnant_pieces.size(), 1u);
  }
}

TEST(PlanOnModel, StructuresFromSeparateMasksArePlannedAsStructuresFromLabels) {
  // Issue 61: structures embedded from masks were label 0, taken for the display skin, and a
  // plane through a tumour and a portal branch reported neither. Now the same findings.
  const Built& labels = built();
  const Built& masks = built_from_masks();
  const double diag = 1.5 * std::sqrt(3.0);
  for (const double x0 : {-30.0, 30.0}) {
    const auto plane = geometry::plane_surface({x0, 0, 0}, {1, 0, 0});
    const geometry::ResectionOptions o;
    const auto a = plan_on_model(labels.model, labels.model.X, plane, o);
    const auto b = plan_on_model(masks.model, masks.model.X, plane, o);
    ASSERT_FALSE(a.tumours.empty());
    ASSERT_FALSE(a.crossings.empty()) << "the plane crosses the vessels";
    EXPECT_NEAR(b.remnant_ml, a.remnant_ml, 1e-3 * a.whole_ml) << x0;
    ASSERT_EQ(b.tumours.size(), a.tumours.size()) << x0;
    for (size_t t = 0; t < a.tumours.size(); ++t) {
      EXPECT_EQ(b.tumours[t].side, a.tumours[t].side) << x0;
      EXPECT_NEAR(b.tumours[t].margin_mm, a.tumours[t].margin_mm, diag) << x0;
    }
    ASSERT_EQ(b.crossings.size(), a.crossings.size()) << x0;
    for (size_t c = 0; c < a.crossings.size(); ++c) {
      EXPECT_EQ(b.crossings[c].name, a.crossings[c].name);
      EXPECT_EQ(b.crossings[c].role, SurfaceRole::kVessel);
      EXPECT_NEAR(b.crossings[c].diameter_mm, a.crossings[c].diameter_mm, 1.0);
    }
  }
}

TEST(PlanOnModel, FollowsTheShapeItIsGiven) {
  // The organ moved 10 mm along the plane's normal: the plane now lies 10 mm deeper in it.
  const Built& b = built();
  const auto plane = geometry::plane_surface({30, 0, 0}, {1, 0, 0});
  const auto moved = geometry::plane_surface({20, 0, 0}, {1, 0, 0});
  const geometry::ResectionOptions o;
  Eigen::MatrixX3d x = b.model.X;
  x.col(0).array() += 10.0;
  const auto a = plan_on_model(b.model, x, plane, o);
  const auto c = plan_on_model(b.model, b.model.X, moved, o);
  EXPECT_NEAR(a.remnant_ml, c.remnant_ml, 1e-6 * c.whole_ml);
  EXPECT_NEAR(a.tumours[1].margin_mm, c.tumours[1].margin_mm, 1e-9);
  EXPECT_THROW(
      plan_on_model(b.model, b.model.X, geometry::plane_surface({0, 0, 300}, {0, 0, 1}), o), Error);
}

TEST(PlanOnModel, CarriesThePortalAndHepaticTreesItWasBuiltWith) {
  const Model& m = built().model;
  ASSERT_EQ(m.trees.size(), 2u);  // the portal vein and the hepatic veins; the tumours are not
  for (const ModelVesselTree& t : m.trees) {
    EXPECT_GE(t.flow.roots, 1) << t.flow.name;
    EXPECT_GT(t.flow.branches(), 1u) << t.flow.name;
    // Each seed sits where it was (at rest its weights give its position back).
    Eigen::MatrixX3d at;
    embedded_positions(t.seeds, m.X, at);
    EXPECT_LT((at - t.seeds.V).cwiseAbs().maxCoeff(), 1e-9) << t.flow.name;
  }
  // The territories partition the tetrahedra: every one is some branch's, all of them summed.
  const ModelTerritories terr = model_territories(m);
  double whole = 0.0;
  for (const double v : terr.sample_ml) whole += v;
  for (const geometry::TreeFlow& f : terr.flows) {
    double sum = 0.0;
    for (const double v : f.branch_territory_ml) sum += v;
    EXPECT_NEAR(sum, whole, 1e-9 * whole) << f.name;
  }
}

TEST(PlanOnModel, GivesTheSegmentationsFunctionalRemnant) {
  // The model's tissue samples by their nearest seed against the segmentation's voxels by
  // theirs: the same tissue cut off, within 5% (and 0.5% of the remnant; measured: 4%). The
  // planes pass between voxel centres: a seed on the plane is taken by one and not the other,
  // and with it every seed downstream.
  const Built& b = built();
  for (const double x0 : {-30.0, -10.6, 5.6, 15.2, 30.0}) {
    const auto plane = geometry::plane_surface({x0, 0, 0}, {1, 0, 0});
    geometry::ResectionOptions o = geometry::planning_phantom_options();
    o.structures.pop_back();  // the vena cava, not embedded
    const auto voxels = geometry::plan_resection(b.volume, geometry::SideOf(plane), o).report;
    const auto model = plan_on_model(b.model, b.model.X, plane, o);
    ASSERT_TRUE(voxels.functional.has_value());
    ASSERT_TRUE(model.functional.has_value()) << model.functional_missing;
    const auto &v = *voxels.functional, &m = *model.functional;
    const double slack = 0.005 * voxels.remnant_ml;
    EXPECT_NEAR(m.devascularized_ml, v.devascularized_ml, 0.05 * v.devascularized_ml + slack) << x0;
    EXPECT_NEAR(m.congested_ml, v.congested_ml, 0.05 * v.congested_ml + slack) << x0;
    EXPECT_NEAR(model.functional_flr_percent, voxels.functional_flr_percent, 0.5) << x0;
    ASSERT_EQ(m.trees.size(), v.trees.size());
    for (size_t t = 0; t < v.trees.size(); ++t) {
      EXPECT_EQ(m.trees[t].name, v.trees[t].name);
      EXPECT_EQ(m.trees[t].divided, v.trees[t].divided) << v.trees[t].name << " at " << x0;
    }
  }
}

TEST(PlanOnModel, TheFunctionalRemnantFollowsTheShape) {
  const Built& b = built();
  Eigen::MatrixX3d x = b.model.X;
  x.col(0).array() += 10.0;
  const geometry::ResectionOptions o;
  // Between voxel centres (a seed on the plane would be taken or not by the last bit of the
  // shifted arithmetic: it was, under ASan's code and not the release's).
  const auto a = plan_on_model(b.model, x, geometry::plane_surface({15.6, 0, 0}, {1, 0, 0}), o);
  const auto c =
      plan_on_model(b.model, b.model.X, geometry::plane_surface({5.6, 0, 0}, {1, 0, 0}), o);
  ASSERT_TRUE(a.functional && c.functional);
  EXPECT_GT(c.functional->lost_ml, 1.0);
  EXPECT_NEAR(a.functional->devascularized_ml, c.functional->devascularized_ml, 1e-6);
  EXPECT_NEAR(a.functional->congested_ml, c.functional->congested_ml, 1e-6);
}

TEST(PlanOnModel, ACutModelKeepsItsTreesAndTheirFunction) {
  // Cut along x = 5.6, then planned along the same plane: the seeds followed their side's copies,
  // and the plan's functional remnant is the uncut model's.
  const Model& m = built().model;
  CutReport report;
  const Model cut = cut_along_x(m, 5.6, report);
  ASSERT_EQ(cut.trees.size(), m.trees.size());
  for (const ModelVesselTree& t : cut.trees) {
    EXPECT_LT(t.seeds.corners.maxCoeff(), cut.node_count());
    Eigen::MatrixX3d at;
    embedded_positions(t.seeds, cut.X, at);
    EXPECT_LT((at - t.seeds.V).cwiseAbs().maxCoeff(), 1e-9) << t.flow.name;
  }
  const auto plane = geometry::plane_surface({5.6, 0, 0}, {1, 0, 0});
  const geometry::ResectionOptions o;
  const auto before = plan_on_model(m, m.X, plane, o), after = plan_on_model(cut, cut.X, plane, o);
  ASSERT_TRUE(before.functional && after.functional);
  EXPECT_NEAR(after.functional->lost_ml, before.functional->lost_ml,
              0.05 * before.functional->lost_ml + 1.0);
  // Territories made for the uncut tetrahedra are refused for the cut ones, never misread.
  const ModelTerritories old = model_territories(m);
  EXPECT_THROW(functional_on_model(cut, old, cut.X, {5.6, 0, 0}, {1, 0, 0}, true, 100.0), Error);
  // The remnant kept after the cut keeps the trees whose every seed it holds.
  const std::vector<uint8_t> keep = nodes_of_pieces_on_side(cut, {5.6, 0, 0}, {1, 0, 0}, false);
  std::vector<int32_t> index;
  const Model rem = keep_nodes(cut, keep, index);
  for (const ModelVesselTree& t : rem.trees)
    EXPECT_LT(t.seeds.corners.maxCoeff(), rem.node_count()) << t.flow.name;
}

TEST(PlanOnModel, WithoutTreesTheFunctionalRemnantIsNotClaimed) {
  Model m = built().model;
  m.trees.clear();
  const auto r = plan_on_model(m, m.X, geometry::plane_surface({5, 0, 0}, {1, 0, 0}), {});
  EXPECT_FALSE(r.functional.has_value());
  EXPECT_NE(r.functional_missing.find("carries no vessel trees"), std::string::npos);
}

TEST(KeepPiece, TheRemnantAfterAPlanesCutIsAWholeModelOfItsVolume) {
  // The plane x = 30 cuts the phantom in two; the pieces behind it (x < 30) kept: their volume is
  // the cut's larger piece's, every element refers to nodes it has, the tetrahedra keep their
  // orientation, the display skin and the structures keep only what the kept nodes carry, and
  // the remnant simulates.
  const Model& m = built().model;
  CutReport report;
  const Model cut = cut_along_x(m, 30.0, report);
  const std::vector<uint8_t> keep = nodes_of_pieces_on_side(cut, {30, 0, 0}, {1, 0, 0}, false);
  std::vector<int32_t> index;
  const Model rem = keep_nodes(cut, keep, index);
  double volume = 0.0;
  for (Eigen::Index t = 0; t < rem.tets.T.rows(); ++t) {
    for (int c = 0; c < 4; ++c) ASSERT_LT(rem.tets.T(t, c), rem.node_count());
    const Eigen::Vector3d a = rem.X.row(rem.tets.T(t, 0)), b = rem.X.row(rem.tets.T(t, 1)),
                          c = rem.X.row(rem.tets.T(t, 2)), d = rem.X.row(rem.tets.T(t, 3));
    const double v = (b - a).dot((c - a).cross(d - a)) / 6.0;
    ASSERT_GT(v, 0.0);
    volume += v * rem.tets.share_of(t);
  }
  EXPECT_NEAR(volume, report.pieces[0].volume_mm3, 1e-9 * volume);
  EXPECT_LT(rem.node_count(), cut.node_count());
  for (const ModelLayer& l : rem.layers)
    if (l.F.rows() > 0) EXPECT_LT(l.F.maxCoeff(), rem.node_count());
  for (size_t e = 0; e < rem.springs.size(); ++e) ASSERT_LT(rem.springs.j[e], rem.node_count());
  ASSERT_FALSE(rem.embedded.empty());
  for (const EmbeddedSurface& e : rem.embedded) {
    EXPECT_LT(e.corners.maxCoeff(), rem.node_count()) << e.name;
    if (e.F.rows() > 0) EXPECT_LT(e.F.maxCoeff(), e.V.rows()) << e.name;
    // Nothing of the resected side (x > 30 at rest) is carried on, bar the cut's own face.
    EXPECT_LT(e.V.col(0).maxCoeff(), 30.0 + 1e-6) << e.name;
  }
  EXPECT_EQ(rem.rings.locality, m.rings.locality);
  EXPECT_EQ(static_cast<int64_t>(rem.rings.offsets.size()),
            static_cast<int64_t>(rem.node_count()) * rem.rings.locality + 1);
}

}  // namespace
}  // namespace lamina::model
