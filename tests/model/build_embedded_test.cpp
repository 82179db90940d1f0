// lamina build's display skin and embedded structures (issue 33): made from the phantom with
// anatomy, carried by the tetrahedra, deformed exactly as W x under the default poke, and bad
// embeddings refused before any work with one line naming the file and the label. Issue 46:
// label maps with the structures carved out of the organ's label (IRCAD's layout, LiTS's, and
// TotalSegmentator's with its structures beside the liver) build as the whole organ, each
// structure closed and enclosing its voxels' volume, none of them moving more than twice as far
// as its tetrahedron.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <memory>

#include "lamina/core/error.h"
#include "lamina/geometry/make_phantom.h"
#include "lamina/geometry/mask_filters.h"
#include "lamina/geometry/mesh_measures.h"
#include "lamina/geometry/plug_tunnels.h"
#include "lamina/interact/run_tools.h"
#include "lamina/io/label_volume_io.h"
#include "lamina/io/scene_model.h"
#include "lamina/model/build_model.h"
#include "lamina/model/embed_surface.h"
#include "lamina/model/summarize_model.h"
#include "support/temp_dir.h"
#include "support/test_paths.h"

namespace {

using namespace lamina;

LabelVolume anatomy(double spacing_mm) {
  LabelVolume v =
      geometry::make_phantom({.spacing_mm = {spacing_mm, spacing_mm, spacing_mm}, .anatomy = true});
  v.source = "anatomy.nii.gz";
  return v;
}

model::BuildOptions with_structures() {
  model::BuildOptions o;
  o.display_triangles = 5000;
  o.structure_triangles = 2000;
  o.embed = {{.name = "vessels", .label = geometry::kPhantomVessel},
             {.name = "tumour", .label = geometry::kPhantomTumour}};
  return o;
}

// The default scene on the 3 mm phantom with anatomy, written to `dir` and built with the
// structures, as `lamina run` would.
io::ReadyScene anatomy_scene(const test::TempDir& dir) {
  const std::string path = dir.file("anatomy.nii.gz");
  io::write_label_volume(anatomy(3.0), path);
  io::Scene scene;
  scene.input = path;
  scene.build = with_structures();
  return io::make_ready_scene(scene);
}

TEST(BuildEmbedded, TheDisplaySkinAndStructuresAreCarriedByTheTetrahedra) {
  const model::BuildResult built = model::build_model(anatomy(3.0), with_structures());
  const Model& m = built.model;
  ASSERT_EQ(m.embedded.size(), 3u);
  EXPECT_EQ(m.embedded[0].name, "display_skin");
  EXPECT_EQ(m.embedded[1].name, "vessels");
  EXPECT_EQ(m.embedded[1].label, geometry::kPhantomVessel);
  EXPECT_EQ(m.embedded[2].name, "tumour");
  ASSERT_EQ(built.report.embedded.size(), 3u);
  // The tumour lies deep inside: every vertex in a tetrahedron. The tree leaves at the hilum.
  EXPECT_EQ(m.embedded[2].outside, 0);
  EXPECT_LT(m.embedded[1].outside, m.embedded[1].V.rows() / 10);
  for (const EmbeddedSurface& e : m.embedded) {
    const geometry::MeshQuality q = geometry::measure_mesh({e.V, e.F});
    EXPECT_TRUE(q.closed && q.manifold && q.outward) << e.name;
    // At rest the map gives the surface back.
    Eigen::MatrixX3d x;
    model::embedded_positions(e, m.X, x);
    EXPECT_LT((x - e.V).cwiseAbs().maxCoeff(), 1e-9) << e.name;
  }
  // The display skin encloses the mask's volume (within 2% at only 5,000 triangles on 3 mm
  // voxels; the 1% target at full budgets is DisplaySkin's); the tumour its 14.1 mL.
  EXPECT_NEAR(built.report.embedded[0].volume_ml, built.report.mask_volume_ml,
              0.02 * built.report.mask_volume_ml);
  EXPECT_NEAR(built.report.embedded[2].volume_ml, 14.1, 0.15 * 14.1);
}

TEST(BuildEmbedded, SeveralLabelsMakeOneOrganTheirUnion) {
  model::BuildOptions o;
  o.display_triangles = 0;
  o.labels = {geometry::kPhantomLiver, geometry::kPhantomVessel, geometry::kPhantomTumour};
  const model::BuildResult all = model::build_model(anatomy(3.0), o);
  EXPECT_TRUE(all.model.embedded.empty());
  o.labels = {};
  const model::BuildResult any = model::build_model(anatomy(3.0), o);
  EXPECT_EQ(all.report.mask.kept_voxels, any.report.mask.kept_voxels);
  o.labels = {geometry::kPhantomLiver, 9};
  try {
    model::build_model(anatomy(3.0), o);
    ADD_FAILURE() << "an absent label among several was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("label 9 is absent"), std::string::npos) << e.what();
  }
}

// What one refused build says.
std::string refusal(const LabelVolume& volume, const model::BuildOptions& o) {
  try {
    model::build_model(volume, o);
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::kInvalidInput);
    const std::string what = e.what();
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    return what;
  }
  ADD_FAILURE() << "accepted";
  return "";
}

TEST(BuildEmbedded, BadEmbeddingsAreRefusedByFileAndLabel) {
  const LabelVolume v = anatomy(4.0);
  model::BuildOptions o = with_structures();
  o.embed = {{.name = "portal", .label = 7}};
  std::string what = refusal(v, o);
  EXPECT_NE(what.find("anatomy.nii.gz"), std::string::npos) << what;
  EXPECT_NE(what.find("label 7"), std::string::npos) << what;
  EXPECT_NE(what.find("absent"), std::string::npos) << what;

  // A label that is the organ's and a structure too is the union layout (issue 61); but the
  // organ cannot be that structure alone.
  o.label = geometry::kPhantomLiver;
  o.embed = {{.name = "liver again", .label = geometry::kPhantomLiver}};
  what = refusal(v, o);
  EXPECT_NE(what.find("every voxel selected as the organ is an embedded structure's"),
            std::string::npos)
      << what;
  o.embed = {
      {.name = "liver again", .label = geometry::kPhantomLiver, .role = SurfaceRole::kWound}};
  what = refusal(v, o);
  EXPECT_NE(what.find("structure 'liver again': a structure is a vessel, a tumour or a structure, "
                      "not a wound"),
            std::string::npos)
      << what;

  o = with_structures();
  o.embed[1].name = "vessels";
  EXPECT_NE(refusal(v, o).find("two structures are named 'vessels'"), std::string::npos);

  o = with_structures();
  o.structure = model::Structure::kLinks;
  EXPECT_NE(refusal(v, o).find("tetrahedra"), std::string::npos);

  // A separate mask on another grid, and an empty one.
  o = with_structures();
  auto other = std::make_shared<LabelVolume>(anatomy(5.0));
  other->source = "other.nii.gz";
  o.embed = {{.name = "elsewhere", .mask = other}};
  what = refusal(v, o);
  EXPECT_NE(what.find("other.nii.gz"), std::string::npos) << what;
  EXPECT_NE(what.find("grid"), std::string::npos) << what;
  auto empty = std::make_shared<LabelVolume>(v);
  std::fill(empty->labels.begin(), empty->labels.end(), 0);
  empty->source = "empty.nii.gz";
  o.embed = {{.name = "nothing", .mask = empty}};
  what = refusal(v, o);
  EXPECT_NE(what.find("empty.nii.gz"), std::string::npos) << what;
  EXPECT_NE(what.find("empty"), std::string::npos) << what;
}

// The default poke on the phantom with anatomy: the structures follow W x exactly, and the
// tumour, which lies under the poked (most anterior) skin, moves back with the dent.
TEST(BuildEmbedded, UnderTheDefaultPokeTheStructuresMoveWithTheTissue) {
  test::TempDir dir;
  const io::ReadyScene ready = anatomy_scene(dir);
  const Model& m = *ready.model;
  ASSERT_EQ(m.embedded.size(), 3u);
  interact::ToolDriver driver = io::make_tool_driver(ready.scene);
  ASSERT_EQ(driver.tools.size(), 1u);
  const int32_t poked = driver.tools[0].vertex;
  sim::Simulation s = io::make_scene_simulation(ready);
  interact::run_tools(s, driver, 0.8, false);  // held until 1 s: mid-push
  const double dent = s.x(poked, 1) - m.X(poked, 1);
  ASSERT_GT(dent, 1.0) << "the poke pushes posteriorly (+y)";
  for (const EmbeddedSurface& e : m.embedded) {
    Eigen::MatrixX3d x;
    model::embedded_positions(e, s.x, x);
    for (Eigen::Index v = 0; v < e.V.rows(); ++v) {
      Eigen::RowVector3d w = Eigen::RowVector3d::Zero();
      for (int c = 0; c < 4; ++c) w += e.weights(v, c) * s.x.row(e.corners(v, c));
      if (e.offsets.rows() > 0) w += e.offsets.row(v);
      ASSERT_LT((x.row(v) - w).norm(), 1e-12 * (1.0 + w.norm())) << e.name << " vertex " << v;
    }
  }
  // The structure vertex nearest the poked node at rest moves posteriorly with the dent.
  Eigen::MatrixX3d tumour;
  model::embedded_positions(m.embedded[2], s.x, tumour);
  Eigen::Index near = 0;
  (m.embedded[2].V.rowwise() - m.X.row(poked)).rowwise().squaredNorm().minCoeff(&near);
  const double moved = tumour(near, 1) - m.embedded[2].V(near, 1);
  EXPECT_GT(moved, 0.1 * dent) << "tumour " << moved << " mm, skin " << dent << " mm, "
                               << (m.embedded[2].V.row(near) - m.X.row(poked)).norm()
                               << " mm apart";
}

// A push over the vessel tree (the skin node nearest to it, towards it): the vessel under the
// dent moves with it, by the tetrahedra that carry it.
TEST(BuildEmbedded, AVesselUnderAPushMovesWithTheDent) {
  test::TempDir dir;
  const io::ReadyScene ready = anatomy_scene(dir);
  const Model& m = *ready.model;
  const EmbeddedSurface& vessels = m.embedded.at(1);
  ASSERT_EQ(vessels.name, "vessels");
  // The skin node nearest to the tree, and the tree's vertex nearest to that node.
  const int32_t skin = m.layers[0].node_count;
  double best = 1e300;
  int32_t node = -1;
  Eigen::Index vertex = 0;
  for (int32_t i = 0; i < skin; ++i) {
    Eigen::Index v = 0;
    const double d = (vessels.V.rowwise() - m.X.row(i)).rowwise().squaredNorm().minCoeff(&v);
    if (d < best) best = d, node = i, vertex = v;
  }
  const Eigen::Vector3d towards = (vessels.V.row(vertex) - m.X.row(node)).transpose().normalized();
  interact::ToolDriver driver = io::make_tool_driver(ready.scene);
  driver.tools = {{.vertex = node, .force_mn = 400.0 * towards, .end_s = 1.0}};
  sim::Simulation s = io::make_scene_simulation(ready);
  interact::run_tools(s, driver, 0.8, false);  // mid-push
  const double dent = (s.x.row(node) - m.X.row(node)).dot(towards.transpose());
  ASSERT_GT(dent, 1.0) << "the push dents the skin over the tree";
  Eigen::MatrixX3d x;
  model::embedded_positions(vessels, s.x, x);
  const double moved = (x.row(vertex) - vessels.V.row(vertex)).dot(towards.transpose());
  EXPECT_GT(moved, 0.5 * dent) << "vessel " << moved << " mm, skin " << dent << " mm, "
                               << std::sqrt(best) << " mm apart";
  std::cout << "skin dented " << dent << " mm; the vessel " << std::sqrt(best)
            << " mm under it moved " << moved << " mm\n";
}

// --- Issue 46: carved-out label maps. ---

int64_t count_label(const LabelVolume& v, int32_t label) {
  return std::count(v.labels.begin(), v.labels.end(), label);
}

int64_t count_non_zero(const LabelVolume& v) {
  return std::count_if(v.labels.begin(), v.labels.end(), [](int32_t l) { return l != 0; });
}

// The carved-out phantom at 1.2 mm, the finest at which a test builds in about a second and
// the organ's label alone still fails (its tunnels cross the skin: ExplainFailure).
const LabelVolume& carved() {
  static const LabelVolume v = [] {
    LabelVolume c = geometry::make_phantom({.spacing_mm = {1.2, 1.2, 1.2}, .carved_out = true});
    c.source = "carved.nii.gz";
    return c;
  }();
  return v;
}

// The organ without anatomy on the same grid: the ground truth of "the organ".
const LabelVolume& whole() {
  static const LabelVolume v = geometry::make_phantom({.spacing_mm = {1.2, 1.2, 1.2}});
  return v;
}

model::BuildOptions carved_options() {
  model::BuildOptions o;
  o.label = geometry::kPhantomLiver;
  o.display_triangles = 5000;
  o.structure_triangles = 3000;
  o.embed = {{.name = "portal vein", .label = geometry::kPhantomVessel},
             {.name = "tumours", .label = geometry::kPhantomTumour},
             {.name = "hepatic veins", .label = geometry::kPhantomHepaticVeins},
             {.name = "vena cava", .label = geometry::kPhantomVenaCava}};
  return o;
}

const model::BuildResult& ircad() {
  static const model::BuildResult r = model::build_model(carved(), carved_options());
  return r;
}

// Each embedded structure: closed, manifold and outward, enclosing its voxels' volume within 3%;
// no vertex amplifying its tetrahedron's motion more than 2x.
void expect_structures_whole(const model::BuildResult& r, const LabelVolume& v,
                             const model::BuildOptions& o) {
  ASSERT_EQ(r.model.embedded.size(), o.embed.size() + 1);
  for (size_t s = 0; s < o.embed.size(); ++s) {
    const EmbeddedSurface& e = r.model.embedded[s + 1];
    const geometry::MeshQuality q = geometry::measure_mesh({e.V, e.F});
    EXPECT_TRUE(q.closed && q.manifold && q.outward) << e.name;
    const double voxels_mm3 =
        static_cast<double>(count_label(v, o.embed[s].label)) * v.frame.voxel_volume_mm3();
    EXPECT_NEAR(q.volume_mm3, voxels_mm3, 0.03 * voxels_mm3) << e.name;
  }
  for (const EmbeddedSurface& e : r.model.embedded)
    EXPECT_LE(model::max_amplification(e), kMaxAmplification) << e.name;
}

TEST(CarvedOut, IrcadsLayoutBuildsTheWholeOrganWithItsStructuresInside) {
  const model::BuildResult& r = ircad();
  // The organ: its label and the structures' voxels inside it, within 1% of the phantom's
  // organ (the vena cava's share of the groove in its back stays out: 0.5% here).
  const double organ = static_cast<double>(count_non_zero(whole()));
  EXPECT_NEAR(static_cast<double>(r.report.mask.kept_voxels), organ, 0.01 * organ);
  EXPECT_EQ(r.report.mask.cavity_voxels_filled, 0) << "the structures fill the organ, not this";
  expect_structures_whole(r, carved(), carved_options());
  // The tumours lie inside (but for the 6 mm bulge of the subcapsular one), the vena cava and
  // the portal trunk largely outside; each structure is reported.
  const geometry::EnclosedCounts& c = r.report.mask.structures;
  ASSERT_EQ(c.voxels.size(), 4u);
  EXPECT_GT(c.inside[1], 0.9 * static_cast<double>(c.voxels[1]));
  EXPECT_LT(c.inside[3], 0.2 * static_cast<double>(c.voxels[3]));
  EXPECT_LT(c.inside[0], c.voxels[0]);
  EXPECT_EQ(r.report.structure_names[3], "vena cava");
  EXPECT_EQ(r.report.skin_genus, 0);
  // The vena cava's far vertices follow by offsets.
  EXPECT_GT(model::offset_vertices(r.model.embedded[4]), r.model.embedded[4].V.rows() / 2);
}

TEST(CarvedOut, LitsLayoutATumourCarvedOutOfTheLiverBuildsTheWholeOrgan) {
  // LiTS stores liver (vessels included) and tumour: the phantom's organ as label 1, both
  // lesions as label 3, the subcapsular one reaching the surface and bulging out of it.
  LabelVolume lits = whole();
  lits.source = "lits.nii.gz";
  for (size_t v = 0; v < lits.labels.size(); ++v)
    if (carved().labels[v] == geometry::kPhantomTumour) lits.labels[v] = geometry::kPhantomTumour;
  model::BuildOptions o;
  o.label = geometry::kPhantomLiver;
  o.display_triangles = 5000;
  o.structure_triangles = 3000;
  o.embed = {{.name = "tumour", .label = geometry::kPhantomTumour}};
  const model::BuildResult r = model::build_model(lits, o);
  // A tumour is the organ's tissue, all of it: the crater it leaves in label 1 is filled and its
  // bulge beyond the organ's outline is organ too (LiTS's whole liver is label 1 with label 2).
  const geometry::EnclosedCounts& c = r.report.mask.structures;
  EXPECT_EQ(c.inside[0], c.voxels[0]);
  EXPECT_GT(c.by_whole, 0) << "the bulge is taken in whole";
  EXPECT_EQ(r.report.structure_roles[0], SurfaceRole::kTumour);
  const double organ = static_cast<double>(count_non_zero(lits));
  EXPECT_NEAR(static_cast<double>(r.report.mask.kept_voxels), organ, 1e-9 * organ);
  expect_structures_whole(r, lits, o);
}

// --- Issue 61: every layout as it comes. ---

// The wrapped variant (the vena cava through a bridge of caudate tissue, the hepatic veins
// draining into it inside, the right one reaching the lateral surface, a lesion bulging 12 mm
// out) carved out of label 1, and the same organ's whole mask.
const LabelVolume& wrapped() {
  static const LabelVolume v = [] {
    LabelVolume c = geometry::make_phantom(
        {.spacing_mm = {1.2, 1.2, 1.2}, .carved_out = true, .wrapped = true});
    c.source = "wrapped.nii.gz";
    return c;
  }();
  return v;
}

const LabelVolume& wrapped_whole() {
  static const LabelVolume v =
      geometry::make_phantom({.spacing_mm = {1.2, 1.2, 1.2}, .wrapped = true});
  return v;
}

Mask label_mask(const LabelVolume& v, int32_t label) {
  Mask m;
  m.frame = v.frame;
  m.inside.resize(v.labels.size());
  for (size_t i = 0; i < v.labels.size(); ++i) m.inside[i] = v.labels[i] == label;
  return m;
}

TEST(EveryLayout, AVenaCavaTheLiverWrapsAndVeinsThroughItBuildTheWholeOrgan) {
  // Label 1 alone has tunnels: the vena cava through the bridge, the veins to the surface.
  Mask liver = label_mask(wrapped(), geometry::kPhantomLiver);
  geometry::keep_largest_component(liver);
  geometry::fill_cavities(liver);
  ASSERT_LT(geometry::euler_characteristic(liver), 0);
  const model::BuildResult r = model::build_model(wrapped(), carved_options());
  // Inside the bridge the vena cava is the organ's (the ray rule: the organ surrounds it);
  // above and below, and the portal trunk, it is not.
  EXPECT_GT(r.report.mask.structures.by_rays, 0);
  EXPECT_EQ(r.report.skin_genus, 0);
  // The skin within 3% of the same organ's whole mask (issue 61's target), the mask within 1%.
  const double whole_ml = static_cast<double>(count_non_zero(wrapped_whole())) *
                          wrapped_whole().frame.voxel_volume_mm3() / 1000.0;
  const double skin_ml = geometry::enclosed_volume(model::layer_mesh(r.model, 0)) / 1000.0;
  EXPECT_NEAR(skin_ml, whole_ml, 0.03 * whole_ml);
  EXPECT_NEAR(r.report.mask_volume_ml, whole_ml, 0.01 * whole_ml);
  expect_structures_whole(r, wrapped(), carved_options());
  // Each structure embedded with its role, the tumours whole.
  ASSERT_EQ(r.model.embedded.size(), 5u);
  EXPECT_EQ(r.model.embedded[0].role, SurfaceRole::kDisplaySkin);
  EXPECT_EQ(r.model.embedded[1].role, SurfaceRole::kVessel);
  EXPECT_EQ(r.model.embedded[2].role, SurfaceRole::kTumour);
  const geometry::EnclosedCounts& c = r.report.mask.structures;
  EXPECT_EQ(c.inside[1], c.voxels[1]);
}

TEST(EveryLayout, TheUnionLayoutBuildsWithItsStructuresEmbedded) {
  // --label 1,2,3,4,5 --embed 2=...,5=...: every structure voxel is organ (the trunks too: the
  // user said so), and each is embedded as well; before issue 61 this was refused.
  model::BuildOptions o = carved_options();
  o.label = 0;
  o.labels = {1, 2, 3, 4, 5};
  const model::BuildResult r = model::build_model(carved(), o);
  const double all = static_cast<double>(count_non_zero(carved()));
  EXPECT_NEAR(static_cast<double>(r.report.mask.kept_voxels), all, 0.01 * all);
  EXPECT_EQ(r.report.mask.structures.added, 0) << "nothing to take in: it is all organ";
  ASSERT_EQ(r.model.embedded.size(), 5u);
  expect_structures_whole(r, carved(), o);
}

TEST(EveryLayout, SeparateMasksGiveTheStructuresTheirRolesAsLabelsDo) {
  // The same anatomy as masks of their own beside a whole-organ mask: the same roles, the
  // same surfaces (issue 61: masks used to be embedded as label 0, read as the display skin).
  LabelVolume organ = whole();
  organ.source = "organ.nii.gz";
  model::BuildOptions o;
  o.display_triangles = 5000;
  o.structure_triangles = 3000;
  const char* names[] = {"portal vein", "tumours", "hepatic veins", "vena cava"};
  const int32_t labels[] = {geometry::kPhantomVessel, geometry::kPhantomTumour,
                            geometry::kPhantomHepaticVeins, geometry::kPhantomVenaCava};
  for (int s = 0; s < 4; ++s) {
    auto mask = std::make_shared<LabelVolume>(carved());
    for (int32_t& l : mask->labels) l = l == labels[s] ? 1 : 0;
    mask->source = std::string(names[s]) + ".nii.gz";
    o.embed.push_back({.name = names[s], .mask = mask});
  }
  const model::BuildResult r = model::build_model(organ, o);
  ASSERT_EQ(r.model.embedded.size(), 5u);
  const SurfaceRole roles[] = {SurfaceRole::kVessel, SurfaceRole::kTumour, SurfaceRole::kVessel,
                               SurfaceRole::kVessel};
  for (int s = 0; s < 4; ++s) {
    EXPECT_EQ(r.model.embedded[s + 1].role, roles[s]) << names[s];
    EXPECT_EQ(r.model.embedded[s + 1].label, 0) << "a separate mask's every non-zero voxel";
  }
  EXPECT_EQ(model::display_skin_index(r.model), 0);
}

TEST(CarvedOut, TotalSegmentatorsNeighboursBesideTheLiverStillBuild) {
  // Its structures lie beside the liver, not carved out of it: the liver takes in little.
  LabelVolume v =
      io::read_label_volume(test::real_data("liver_totalseg_example_3mm_labels.nii.gz"));
  model::BuildOptions o;
  o.label = 1;
  o.display_triangles = 5000;
  o.structure_triangles = 3000;
  o.embed = {{.name = "portal vein", .label = 2},
             {.name = "vena cava", .label = 3},
             {.name = "gallbladder", .label = 4}};
  const model::BuildResult r = model::build_model(v, o);
  const double liver = static_cast<double>(count_label(v, 1));
  EXPECT_NEAR(static_cast<double>(r.report.mask.kept_voxels), liver, 0.01 * liver);
  expect_structures_whole(r, v, o);
}

TEST(CarvedOut, NoEmbeddedVertexMovesMoreThanTwiceItsTetrahedron) {
  // The IRCAD build poked as `lamina run` pokes by default: the vena cava, mostly outside the
  // organ, moves with it without amplifying its tetrahedra's motion.
  test::TempDir dir;
  const std::string path = dir.file("carved.nii.gz");
  io::write_label_volume(carved(), path);
  io::Scene scene;
  scene.input = path;
  scene.build = carved_options();
  const io::ReadyScene ready = io::make_ready_scene(scene);
  const Model& m = *ready.model;
  interact::ToolDriver driver = io::make_tool_driver(ready.scene);
  sim::Simulation s = io::make_scene_simulation(ready);
  interact::run_tools(s, driver, 0.8, false);  // mid-push
  double worst = 0.0, largest = 0.0;
  for (const EmbeddedSurface& e : m.embedded) {
    Eigen::MatrixX3d x;
    model::embedded_positions(e, s.x, x);
    for (Eigen::Index v = 0; v < e.V.rows(); ++v) {
      double corner_motion = 0.0;
      for (int c = 0; c < 4; ++c)
        corner_motion =
            std::max(corner_motion, (s.x.row(e.corners(v, c)) - m.X.row(e.corners(v, c))).norm());
      const double motion = (x.row(v) - e.V.row(v)).norm();
      largest = std::max(largest, motion);
      if (corner_motion > 1e-6) worst = std::max(worst, motion / corner_motion);
      ASSERT_LE(motion, kMaxAmplification * corner_motion + 1e-9) << e.name << " vertex " << v;
    }
  }
  EXPECT_GT(largest, 1.0) << "the poke moved the structures";
  std::cout << "largest motion " << largest << " mm; largest amplification " << worst << "\n";
}

TEST(CarvedOut, AStructureOutsideTheOrganOrAnOrganOfStructuresAloneIsRefused) {
  // A blob in the scan's corner, far from the organ, as a structure.
  LabelVolume v = carved();
  for (int64_t k = 0; k < 4; ++k)
    for (int64_t j = 0; j < 4; ++j)
      for (int64_t i = 0; i < 4; ++i) v.labels[static_cast<size_t>(v.frame.index(i, j, k))] = 9;
  model::BuildOptions o = carved_options();
  o.embed.push_back({.name = "kidney", .label = 9});
  std::string what = refusal(v, o);
  EXPECT_NE(what.find("carved.nii.gz"), std::string::npos) << what;
  EXPECT_NE(what.find("label 9 (structure 'kidney'): none of its 64 voxels lies inside the organ"),
            std::string::npos)
      << what;
  // Every label embedded and the organ any non-zero one: it would be structures alone.
  o = carved_options();
  o.label = 0;
  o.embed.push_back({.name = "parenchyma", .label = geometry::kPhantomLiver});
  what = refusal(carved(), o);
  EXPECT_NE(what.find("every voxel selected as the organ is an embedded structure's"),
            std::string::npos)
      << what;
}

}  // namespace
