#include "lamina/model/build_model.h"

#include <gtest/gtest.h>

#include <array>
#include <filesystem>
#include <map>
#include <numeric>
#include <set>

#include "lamina/core/error.h"
#include "lamina/geometry/make_phantom.h"
#include "lamina/geometry/remesh.h"
#include "lamina/io/label_volume_io.h"
#include "lamina/io/mesh_file.h"
#include "lamina/io/model_file.h"
#include "lamina/model/compute_rings.h"
#include "lamina/model/summarize_model.h"
#include "support/test_paths.h"
#include "support/volumes.h"

namespace {

using namespace lamina;

// Each build takes around a second: build every input once and share it between tests.
const model::BuildResult& built(const std::string& input) {
  static std::map<std::string, model::BuildResult> cache;
  auto it = cache.find(input);
  if (it == cache.end()) {
    const LabelVolume v = input == "phantom" ? geometry::make_phantom()
                                             : io::read_label_volume(test::real_data(input));
    it = cache.emplace(input, model::build_model(v, {})).first;
  }
  return it->second;
}

class BuildOnOrgan : public ::testing::TestWithParam<std::string> {};

INSTANTIATE_TEST_SUITE_P(PhantomAndRealMasks, BuildOnOrgan,
                         ::testing::Values("phantom", "liver_sofa_smooth_voxelized_1mm.nii.gz",
                                           "liver_totalseg_example_3mm.nii.gz",
                                           "kidney_right_totalseg_example_3mm.nii.gz"),
                         [](const auto& info) {
                           std::string n = info.param.substr(0, info.param.find('.'));
                           for (char& c : n)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return n;
                         });

TEST_P(BuildOnOrgan, EveryLayerIsAClosedOutwardManifoldWithoutDefects) {
  const auto& b = built(GetParam());
  ASSERT_EQ(b.model.layer_count(), 2);
  const model::ModelSummary s = model::summarize_model(b.model);
  for (const auto& l : s.layers) {
    SCOPED_TRACE("layer " + std::to_string(l.index));
    EXPECT_TRUE(l.quality.closed);
    EXPECT_TRUE(l.quality.manifold);
    EXPECT_TRUE(l.quality.outward);
    EXPECT_EQ(l.quality.degenerate_faces, 0);
    EXPECT_FALSE(l.self_intersecting);
    EXPECT_GT(l.quality.min_angle_deg, 1.0);
  }
  EXPECT_EQ(s.layers[0].quality.components, 1);
}

TEST_P(BuildOnOrgan, LayersNestStrictly) {
  const model::ModelSummary s = model::summarize_model(built(GetParam()).model);
  for (size_t k = 1; k < s.layers.size(); ++k) {
    EXPECT_TRUE(s.layers[k].nested) << "layer " << k;
    EXPECT_GT(s.layers[k].min_gap_mm, 0.0);
    EXPECT_LT(s.layers[k].quality.volume_mm3, s.layers[k - 1].quality.volume_mm3);
  }
}

TEST_P(BuildOnOrgan, SkinVolumeWithinThreePercentOfTheMask) {
  const auto& b = built(GetParam());
  const double skin_ml = model::summarize_model(b.model).layers[0].quality.volume_mm3 / 1000.0;
  EXPECT_NEAR(skin_ml / b.report.mask_volume_ml, 1.0, 0.03);
  EXPECT_NEAR(b.report.skin_volume_error_pct, 100.0 * (skin_ml / b.report.mask_volume_ml - 1.0),
              1e-6);
}

TEST_P(BuildOnOrgan, SkinHasAboutThePapersVertexCount) {
  const auto& b = built(GetParam());
  EXPECT_NEAR(b.model.layers[0].node_count, 1284, 1284 * 0.1);
  // Inner layers use the skin's edge length.
  const model::ModelSummary s = model::summarize_model(b.model);
  EXPECT_NEAR(s.layers[1].quality.mean_edge_mm / s.layers[0].quality.mean_edge_mm, 1.0, 0.15);
}

TEST_P(BuildOnOrgan, SpringsAreTheTetrahedraEdgesAndMakeOneBody) {
  const Model& m = built(GetParam()).model;
  const model::ModelSummary s = model::summarize_model(m);
  EXPECT_EQ(s.spring_components, 1);
  ASSERT_GT(s.volume_springs, 0);
  // The springs are exactly the tetrahedra's edges; a layer's triangle edges are kIntraLayer.
  std::set<std::pair<int32_t, int32_t>> edges, layer_edges;
  for (Eigen::Index t = 0; t < m.tets.size(); ++t)
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b)
        edges.emplace(std::min(m.tets.T(t, a), m.tets.T(t, b)),
                      std::max(m.tets.T(t, a), m.tets.T(t, b)));
  for (const ModelLayer& l : m.layers)
    for (Eigen::Index f = 0; f < l.F.rows(); ++f)
      for (int c = 0; c < 3; ++c)
        layer_edges.emplace(std::min(l.F(f, c), l.F(f, (c + 1) % 3)),
                            std::max(l.F(f, c), l.F(f, (c + 1) % 3)));
  ASSERT_EQ(edges.size(), m.springs.size());
  for (size_t e = 0; e < m.springs.size(); ++e) {
    const std::pair<int32_t, int32_t> ij{m.springs.i[e], m.springs.j[e]};
    ASSERT_TRUE(edges.contains(ij));
    EXPECT_EQ(m.springs.kind[e] == SpringKind::kIntraLayer, layer_edges.contains(ij));
  }
  // Every node is a corner of a tetrahedron; interior nodes come after the layers.
  std::vector<int> used(static_cast<size_t>(m.node_count()), 0);
  for (Eigen::Index t = 0; t < m.tets.size(); ++t)
    for (int c = 0; c < 4; ++c) used[m.tets.T(t, c)] = 1;
  EXPECT_EQ(std::accumulate(used.begin(), used.end(), 0), m.node_count());
  for (int32_t i = 0; i < m.node_count(); ++i)
    EXPECT_EQ(m.layer_of[i] == kInteriorNode, i >= m.surface_node_count());
}

TEST_P(BuildOnOrgan, TetrahedraFillTheShellsConformingToTheLayers) {
  const auto& b = built(GetParam());
  const Model& m = b.model;
  // Good tetrahedra: none inverted, no sliver, volumes summing to the volume inside the skin.
  const geometry::TetQuality q = b.report.tets;
  EXPECT_EQ(q.count, m.tets.size());
  EXPECT_EQ(q.inverted, 0);
  EXPECT_EQ(q.slivers, 0);
  EXPECT_GT(q.min_dihedral_deg, 5.0);
  EXPECT_GT(q.mean_dihedral_deg, 60.0);
  const double skin_mm3 = model::summarize_model(m).layers[0].quality.volume_mm3;
  EXPECT_NEAR(q.volume_mm3 / skin_mm3, 1.0, 1e-9);
  // Conforming: each layer triangle is a face of one tetrahedron of the region just inside its
  // layer and, for an inner layer, of one of the region outside it; the skin's of one only.
  std::map<std::array<int, 3>, std::vector<Eigen::Index>> owners;
  for (Eigen::Index t = 0; t < m.tets.size(); ++t)
    for (int c = 0; c < 4; ++c) {
      std::array<int, 3> f{m.tets.T(t, (c + 1) % 4), m.tets.T(t, (c + 2) % 4),
                           m.tets.T(t, (c + 3) % 4)};
      std::sort(f.begin(), f.end());
      owners[f].push_back(t);
    }
  for (int32_t k = 0; k < m.layer_count(); ++k)
    for (Eigen::Index f = 0; f < m.layers[k].F.rows(); ++f) {
      std::array<int, 3> key{m.layers[k].F(f, 0), m.layers[k].F(f, 1), m.layers[k].F(f, 2)};
      std::sort(key.begin(), key.end());
      const auto it = owners.find(key);
      ASSERT_NE(it, owners.end()) << "layer " << k << " triangle " << f;
      ASSERT_EQ(it->second.size(), k == 0 ? 1u : 2u);
      std::vector<int32_t> regions;
      for (Eigen::Index t : it->second) regions.push_back(m.tets.region[static_cast<size_t>(t)]);
      std::sort(regions.begin(), regions.end());
      EXPECT_EQ(regions.back(), k);
      if (k > 0) EXPECT_EQ(regions.front(), k - 1);
    }
}

TEST(BuildModel, LinksJoinEveryNodeToANeighbouringLayer) {
  // The paper's structure, one choice away: nearest-node links between the layers.
  const Model m = model::build_model(geometry::make_phantom({.spacing_mm = {3, 3, 3}}),
                                     {.structure = model::Structure::kLinks, .skin_vertices = 400})
                      .model;
  EXPECT_FALSE(m.has_tets());
  const model::ModelSummary s = model::summarize_model(m);
  EXPECT_EQ(s.spring_components, 1);
  EXPECT_GT(s.inter_layer_springs, 0);
  std::vector<int> linked(static_cast<size_t>(m.node_count()), 0);
  for (size_t e = 0; e < m.springs.size(); ++e)
    if (m.springs.kind[e] == SpringKind::kInterLayer) {
      linked[m.springs.i[e]] = 1;
      linked[m.springs.j[e]] = 1;
      EXPECT_EQ(std::abs(m.layer_of[m.springs.i[e]] - m.layer_of[m.springs.j[e]]), 1);
    } else {
      EXPECT_EQ(m.layer_of[m.springs.i[e]], m.layer_of[m.springs.j[e]]);
    }
  EXPECT_EQ(std::accumulate(linked.begin(), linked.end(), 0), m.node_count());
}

TEST_P(BuildOnOrgan, RestLengthsAndMassesAreConsistent) {
  const Model& m = built(GetParam()).model;
  for (size_t e = 0; e < m.springs.size(); ++e) {
    ASSERT_LT(m.springs.i[e], m.springs.j[e]);
    ASSERT_DOUBLE_EQ(m.springs.rest_length_mm[e],
                     (m.X.row(m.springs.i[e]) - m.X.row(m.springs.j[e])).norm());
    ASSERT_GT(m.springs.rest_length_mm[e], 0.0);
  }
  for (double w : m.mass_kg) ASSERT_GT(w, 0.0);
  const double total = std::accumulate(m.mass_kg.begin(), m.mass_kg.end(), 0.0);
  const double skin_mm3 = model::summarize_model(m).layers[0].quality.volume_mm3;
  EXPECT_NEAR(total / (m.density_kg_per_mm3 * skin_mm3), 1.0, 1e-9);
}

TEST_P(BuildOnOrgan, SavedModelLoadsBackExactly) {
  const Model& m = built(GetParam()).model;
  const auto path = std::filesystem::temp_directory_path() /
                    ("lamina_roundtrip_" + std::to_string(::getpid()) + ".vtu");
  io::save_model(m, path.string());
  const Model l = io::load_model(path.string());
  std::filesystem::remove(path);
  EXPECT_EQ(l.X, m.X);
  EXPECT_EQ(l.mass_kg, m.mass_kg);
  EXPECT_EQ(l.layer_of, m.layer_of);
  EXPECT_EQ(l.springs.i, m.springs.i);
  EXPECT_EQ(l.springs.j, m.springs.j);
  EXPECT_EQ(l.springs.rest_length_mm, m.springs.rest_length_mm);
  EXPECT_EQ(l.springs.stiffness_n_per_m, m.springs.stiffness_n_per_m);
  ASSERT_EQ(l.layer_count(), m.layer_count());
  for (int k = 0; k < m.layer_count(); ++k) EXPECT_EQ(l.layers[k].F, m.layers[k].F);
  // Rings are recomputed on load and come out identical.
  const Rings r = model::compute_rings(l, l.rings.locality);
  EXPECT_EQ(r.offsets, m.rings.offsets);
  EXPECT_EQ(r.members, m.rings.members);
}

TEST(BuildModel, TotalSegLiverTouchingTheScanEdgeStillCloses) {
  const auto& b = built("liver_totalseg_example_3mm.nii.gz");
  EXPECT_TRUE(b.report.mask.touches_scan_border);
  EXPECT_TRUE(model::summarize_model(b.model).layers[0].quality.closed);
}

TEST(BuildModel, SixLayersNestOnThePhantom) {
  const LabelVolume v = geometry::make_phantom({.spacing_mm = {2, 2, 2}});
  const model::BuildResult b = model::build_model(v, {.layers = 6, .skin_vertices = 2000});
  ASSERT_EQ(b.model.layer_count(), 6);
  const model::ModelSummary s = model::summarize_model(b.model);
  for (size_t k = 0; k < s.layers.size(); ++k) {
    EXPECT_TRUE(s.layers[k].quality.closed) << k;
    EXPECT_TRUE(s.layers[k].nested) << k;
    EXPECT_FALSE(s.layers[k].self_intersecting) << k;
  }
  EXPECT_EQ(s.spring_components, 1);
}

TEST(BuildModel, LayerDeeperThanTheOrganVanishesWithAWarning) {
  const LabelVolume v = geometry::make_phantom({.spacing_mm = {3, 3, 3}});
  const model::BuildResult b =
      model::build_model(v, {.layers = 3, .skin_vertices = 500, .layer_depth_mm = 35.0});
  EXPECT_EQ(b.model.layer_count(), 2);  // layer 2 at 70 mm is deeper than the ~54 mm organ
  ASSERT_FALSE(b.report.warnings.empty());
  EXPECT_NE(b.report.warnings.back().find("vanished"), std::string::npos);
}

TEST(BuildModel, InnerLayerSplitsInAThinWaistAndStaysConnected) {
  // Two balls joined by a thin rod: at depth the rod disappears and the inner layer splits.
  LabelVolume v = test::empty_volume(70, 1.0);
  test::paint_sphere(v, v.frame.to_physical(18, 35, 35), 14.0, 1);
  test::paint_sphere(v, v.frame.to_physical(51, 35, 35), 14.0, 1);
  for (int64_t i = 18; i <= 51; ++i)
    for (int64_t j = 32; j <= 38; ++j)
      for (int64_t k = 32; k <= 38; ++k) v.labels[v.frame.index(i, j, k)] = 1;
  const model::BuildResult b = model::build_model(v, {.skin_vertices = 800, .layer_depth_mm = 6.0});
  ASSERT_EQ(b.model.layer_count(), 2);
  const model::ModelSummary s = model::summarize_model(b.model);
  EXPECT_EQ(s.layers[0].quality.components, 1);
  EXPECT_EQ(s.layers[1].quality.components, 2);
  EXPECT_TRUE(s.layers[1].nested);
  EXPECT_EQ(s.spring_components, 1);
  bool reported = false;
  for (const auto& w : b.report.warnings) reported |= w.find("splits into 2") != std::string::npos;
  EXPECT_TRUE(reported);
}

TEST(BuildModel, IsDeterministic) {
  const LabelVolume v = geometry::make_phantom({.spacing_mm = {3, 3, 3}});
  const auto a = model::build_model(v, {.skin_vertices = 400});
  const auto b = model::build_model(v, {.skin_vertices = 400});
  EXPECT_EQ(a.model.X, b.model.X);
  EXPECT_EQ(a.model.springs.i, b.model.springs.i);
  EXPECT_EQ(a.model.springs.j, b.model.springs.j);
}

TEST(BuildModel, RejectsBadOptions) {
  const LabelVolume v = geometry::make_phantom({.spacing_mm = {4, 4, 4}});
  EXPECT_THROW(model::build_model(v, {.layers = 0}), Error);
  EXPECT_THROW(model::build_model(v, {.skin_vertices = 3}), Error);
  EXPECT_THROW(model::build_model(v, {.layer_depth_mm = -1.0}), Error);
  EXPECT_THROW(model::build_model(v, {.locality = 0}), Error);
  EXPECT_THROW(model::build_model(v, {.density_kg_per_mm3 = 0.0}), Error);
}

}  // namespace

namespace {

TEST(BuildModel, SkinFromTheSofaVoxelisationLiesOnTheOriginalSofaMesh) {
  // The shared 1 mm mask is a voxelisation of a real liver mesh (PROVENANCE.md): the skin we
  // rebuild from it must lie on that mesh to within about a voxel. The OBJ is in the NIfTI's
  // RAS frame; ITK (and so Lamina) works in LPS: x and y flip.
  const auto& b = built("liver_sofa_smooth_voxelized_1mm.nii.gz");
  SurfaceMesh sofa = io::read_obj(test::real_data("liver_sofa_smooth_mm.obj"));
  sofa.V.col(0) *= -1.0;
  sofa.V.col(1) *= -1.0;
  const SurfaceMesh skin = model::layer_mesh(b.model, 0);
  const geometry::SurfaceDistance to_sofa = geometry::surface_distance(skin, sofa);
  const geometry::SurfaceDistance from_sofa = geometry::surface_distance(sofa, skin);
  EXPECT_LT(to_sofa.mean_mm, 0.5);
  EXPECT_LT(to_sofa.max_mm, 2.0);
  EXPECT_LT(from_sofa.mean_mm, 0.7);  // the coarser skin cuts corners between its vertices
  EXPECT_LT(from_sofa.max_mm, 3.0);
  RecordProperty("skin_to_sofa_mean_mm", std::to_string(to_sofa.mean_mm));
  RecordProperty("sofa_to_skin_max_mm", std::to_string(from_sofa.max_mm));
}

}  // namespace
