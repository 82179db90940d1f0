// lamina build's display skin and embedded structures (issue 33): made from the phantom with
// anatomy, carried by the tetrahedra, deformed exactly as W x under the default poke, and bad
// embeddings refused before any work with one line naming the file and the label.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <memory>

#include "lamina/core/error.h"
#include "lamina/geometry/make_phantom.h"
#include "lamina/geometry/mesh_measures.h"
#include "lamina/interact/run_tools.h"
#include "lamina/io/label_volume_io.h"
#include "lamina/io/scene_model.h"
#include "lamina/model/build_model.h"
#include "lamina/model/embed_surface.h"
#include "support/temp_dir.h"

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

  o.label = geometry::kPhantomLiver;
  o.embed = {{.name = "liver again", .label = geometry::kPhantomLiver}};
  what = refusal(v, o);
  EXPECT_NE(what.find("also the organ's"), std::string::npos) << what;

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

}  // namespace
