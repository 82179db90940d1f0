// Embedded surfaces in the model file (format versions 3 and 4, docs/model_format.md): a model's
// display skin, a tumour inside it and a surface outside every tetrahedron (far enough out to
// follow by offsets: version 4) come back bit for bit; a model without offsets is still written
// as version 3, one without surfaces as version 2 with the checksum it always had; a name that
// would not read back is refused on save; and a file whose surfaces are inconsistent is refused on
// load with one line naming the problem.
#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "lamina/core/error.h"
#include "lamina/io/model_file.h"
#include "lamina/model/embed_surface.h"
#include "support/meshes.h"
#include "support/model_file_text.h"
#include "support/temp_dir.h"
#include "support/tet_phantom.h"

namespace lamina::io {
namespace {

using namespace lamina::test;

namespace fs = std::filesystem;

// The phantom with three surfaces: its own skin ("display_skin", label 0), a small octahedron
// at the centre of its nodes ("tumour", label 3) and one beyond its right side ("probe", in no
// tetrahedron: its weights extrapolate, some negative, and 20 mm out, some vertices follow by
// offsets).
Model with_surfaces() {
  Model m = tet_phantom();
  const ModelLayer& skin = m.layers[0];
  m.embedded.push_back(model::embed_surface(m, m.X.topRows(skin.node_count), skin.F, "display_skin",
                                            SurfaceRole::kDisplaySkin, 0));
  const Eigen::RowVector3d centre = m.X.colwise().mean();
  const SurfaceMesh tumour = octahedron(5.0 + 1.0 / 3.0, centre);
  m.embedded.push_back(
      model::embed_surface(m, tumour.V, tumour.F, "tumour", SurfaceRole::kTumour, 3));
  const Eigen::RowVector3d beyond(m.X.col(0).maxCoeff() + 20.0, centre.y(), centre.z());
  const SurfaceMesh probe = octahedron(4.0, beyond);
  m.embedded.push_back(
      model::embed_surface(m, probe.V, probe.F, "probe", SurfaceRole::kStructure, 7));
  return m;
}

// The probe's first vertex that follows by an offset.
Eigen::Index first_offset(const Model& m) {
  const Eigen::MatrixX3d& o = m.embedded[2].offsets;
  for (Eigen::Index v = 0; v < o.rows(); ++v)
    if (o.row(v).squaredNorm() > 0.0) return v;
  return 0;
}

int64_t point_count(const Model& m) {
  int64_t points = m.node_count();
  for (const EmbeddedSurface& e : m.embedded) points += e.V.rows();
  return points;
}

// The text of array `name` with its value number `index` (from the end when negative) replaced.
std::string replace_value(std::string text, const std::string& name, int64_t index,
                          const std::string& value) {
  const size_t at = text.find("Name=\"" + name + "\"");
  EXPECT_NE(at, std::string::npos) << name;
  const size_t begin = text.find('>', at) + 1, end = text.find('<', begin);
  std::vector<std::pair<size_t, size_t>> tokens;  // [first, last) of each value
  for (size_t p = begin; p < end;) {
    while (p < end && (text[p] == ' ' || text[p] == '\n')) ++p;
    const size_t first = p;
    while (p < end && text[p] != ' ' && text[p] != '\n') ++p;
    if (p > first) tokens.emplace_back(first, p);
  }
  const auto k =
      static_cast<size_t>(index < 0 ? static_cast<int64_t>(tokens.size()) + index : index);
  EXPECT_LT(k, tokens.size()) << name;
  return text.replace(tokens[k].first, tokens[k].second - tokens[k].first, value);
}

TEST(ModelFileEmbedded, SurfacesRoundTripBitExactly) {
  const TempDir dir;
  const Model m = with_surfaces();
  ASSERT_EQ(m.embedded[2].outside, 6);  // the probe exercises extrapolated weights
  ASSERT_LT(m.embedded[2].weights.minCoeff(), 0.0);
  ASSERT_GT(model::offset_vertices(m.embedded[2]), 0);  // and offsets
  const std::string path = dir.file("model.vtu");
  save_model(m, path);
  const Model loaded = load_model(path);
  expect_same_model(m, loaded);
  EXPECT_EQ(loaded.embedded[1].name, "tumour");
  EXPECT_EQ(loaded.embedded[1].label, 3);

  const std::string text = file_text(path);
  EXPECT_NE(text.find("Name=\"lamina_format_version\" NumberOfTuples=\"1\" format=\"ascii\">\n"
                      "        6\n"),
            std::string::npos);
  // For ParaView (not read back): the organ's colour on the nodes, each surface's on its points.
  EXPECT_NE(text.find("Name=\"color\" NumberOfComponents=\"3\" format=\"ascii\">\n"
                      "          153 56 43 153 56 43"),
            std::string::npos);
  int64_t cells = static_cast<int64_t>(m.springs.size()) + m.tets.size();
  for (const ModelLayer& l : m.layers) cells += l.F.rows();
  for (const EmbeddedSurface& e : m.embedded) cells += e.F.rows();
  EXPECT_NE(text.find("<Piece NumberOfPoints=\"" + std::to_string(point_count(m)) +
                      "\" NumberOfCells=\"" + std::to_string(cells) + "\">"),
            std::string::npos);
}

TEST(ModelFileEmbedded, SurfacesAreWrittenWithTheirRolesAndOldFilesGetTheRolesTheyHad) {
  // Version 6: each surface's role stored; no vertex far enough out needs an offset here, so
  // none is written.
  const TempDir dir;
  Model m = with_surfaces();
  m.embedded.pop_back();
  const std::string path = dir.file("model.vtu");
  save_model(m, path);
  const std::string text = file_text(path);
  EXPECT_NE(text.find("Name=\"lamina_format_version\" NumberOfTuples=\"1\" format=\"ascii\">\n"
                      "        6\n"),
            std::string::npos);
  EXPECT_NE(text.find("Name=\"embedded_role\""), std::string::npos);
  EXPECT_EQ(text.find("embed_offset"), std::string::npos);
  expect_same_model(m, load_model(path));
  // The same model as version 3 wrote it (no roles, its checksum without them): the display
  // skin, and the tumour by its name, as the readers of that time saw them.
  std::string v3 = replace_values(text, "lamina_format_version", "3");
  const size_t role = v3.find("<DataArray type=\"Int32\" Name=\"embedded_role\"");
  ASSERT_NE(role, std::string::npos);
  v3.erase(role, v3.find("</DataArray>", role) + std::string("</DataArray>").size() - role);
  const size_t crc = v3.find("<DataArray type=\"Int64\" Name=\"content_crc32\"");  // none yet
  ASSERT_NE(crc, std::string::npos);
  v3.erase(crc, v3.find("</DataArray>", crc) + std::string("</DataArray>").size() - crc);
  const std::string old_path = dir.file("old.vtu");
  write_text(old_path, v3);
  const Model read = load_model(old_path);
  ASSERT_EQ(read.embedded.size(), m.embedded.size());
  EXPECT_EQ(read.embedded[0].role, SurfaceRole::kDisplaySkin);
  EXPECT_EQ(read.embedded[1].role, SurfaceRole::kTumour);
  // A role that is none is refused by name.
  write_text(old_path, replace_values(text, "embedded_role", "0 9"));
  expect_load_error(old_path, "has role 9");
}

TEST(ModelFileEmbedded, AModelWithoutSurfacesIsStillWrittenAsVersionTwo) {
  // Builds from before version 3 read it, and nothing in it mentions the surfaces.
  const TempDir dir;
  const std::string path = dir.file("model.vtu");
  save_model(tet_phantom(), path);
  const std::string text = file_text(path);
  EXPECT_NE(text.find("Name=\"lamina_format_version\" NumberOfTuples=\"1\" format=\"ascii\">\n"
                      "        2\n"),
            std::string::npos);
  EXPECT_EQ(text.find("embed"), std::string::npos);
  EXPECT_EQ(load_model(path).embedded.size(), 0u);
}

TEST(ModelFileEmbedded, TheChecksumCoversTheSurfacesOnlyWhenThereAreAny) {
  Model m = with_surfaces();
  const uint32_t without = model_fingerprint(tet_phantom()), with = model_fingerprint(m);
  EXPECT_NE(with, without);
  // Each part of a surface counts: one bit of a weight, a name, a label.
  const auto changes = [&](const std::function<void(Model&)>& edit) {
    Model edited = m;
    edit(edited);
    return model_fingerprint(edited) != with;
  };
  EXPECT_TRUE(changes([](Model& e) {
    double& w = e.embedded[1].weights(0, 0);
    w = std::bit_cast<double>(std::bit_cast<uint64_t>(w) ^ 1);
  }));
  EXPECT_TRUE(changes([](Model& e) { e.embedded[1].name = "tumouR"; }));
  EXPECT_TRUE(changes([](Model& e) { e.embedded[2].label = 8; }));
  EXPECT_TRUE(changes([](Model& e) { e.embedded[0].F(0, 0) = e.embedded[0].F(0, 1); }));
  // Names are delimited: "ab" + "c" is not "a" + "bc".
  EXPECT_TRUE(changes([](Model& e) {
    e.embedded[1].name = "tumourp";
    e.embedded[2].name = "robe";
  }));
  m.embedded.clear();
  EXPECT_EQ(model_fingerprint(m), without);  // checkpoints of such models still match
}

TEST(ModelFileEmbedded, ANameThatWouldNotReadBackIsRefusedOnSave) {
  const TempDir dir;
  for (const std::string name : {"", "portal\nvein"}) {
    Model m = with_surfaces();
    m.embedded[1].name = name;
    const std::string path = dir.file("model.vtu");
    try {
      save_model(m, path);
      ADD_FAILURE() << "saved a surface named '" << name << "'";
    } catch (const Error& e) {
      const std::string message = e.what();
      EXPECT_EQ(e.kind(), ErrorKind::kInvalidInput) << message;
      EXPECT_EQ(message.rfind(path + ": cannot save: embedded surface 1 has the name", 0), 0u)
          << message;
      EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    }
    EXPECT_TRUE(fs::is_empty(dir.path));
  }
}

// Models that save_model() writes as they are (it checks only what it would read out of
// bounds) but load_model() must refuse.
TEST(ModelFileEmbedded, InconsistentSurfacesAreRefusedOnLoad) {
  const TempDir dir;
  const std::string path = dir.file("model.vtu");
  const Model base = with_surfaces();
  const int64_t n = base.node_count();
  const int64_t tumour = n + base.embedded[0].V.rows(), probe = tumour + 6;  // their points
  const ModelCorruptions cases = {
      {[](Model& m) { m.embedded[1].weights(2, 0) += 1e-6; },
       "embedded surface 1 ('tumour') vertex 2: weights sum to 1.00000"},
      {[](Model& m) { m.embedded[1].weights(2, 1) = std::nan(""); },
       "embedded surface 1 ('tumour') vertex 2: a weight is not finite"},
      {[n](Model& m) { m.embedded[0].corners(4, 3) = static_cast<int>(n); },
       "embedded surface 0 ('display_skin') vertex 4: corner " + std::to_string(n) +
           " is not a node"},
      {[](Model& m) { m.embedded[1].corners(0, 2) = -1; }, "vertex 0: corner -1 is not a node"},
      {[](Model& m) { m.embedded[2].corners(5, 1) = m.embedded[2].corners(5, 0); },
       "embedded surface 2 ('probe') vertex 5: corner " +
           std::to_string(base.embedded[2].corners(5, 0)) + " appears twice"},
      {[](Model& m) { m.embedded[1].V(3, 1) = INFINITY; },
       "embedded surface 1 ('tumour') vertex 3: position is not finite"},
      // Vertex 6 of the tumour is vertex 0 of the probe.
      {[](Model& m) { m.embedded[1].F(7, 2) = 6; },
       "embedded surface 1 ('tumour') triangle 7 uses point " + std::to_string(probe) +
           ", outside the surface's points [" + std::to_string(tumour) + ", " +
           std::to_string(probe) + ")"},
      {[](Model& m) { m.embedded[2].F(0, 0) = -1; },
       "embedded surface 2 ('probe') triangle 0 uses point " + std::to_string(probe - 1)},
      {[](Model& m) { m.embedded[1].outside = 7; },
       "embedded surface 1 ('tumour') has 6 vertices, 8 triangles and 7 vertices outside"},
      {[](Model& m) { m.embedded[2].offsets(first_offset(m), 2) = std::nan(""); },
       "embedded surface 2 ('probe') vertex " + std::to_string(first_offset(base)) +
           ": an offset is not finite"},
      // Weights that would amplify the motion more than the offsets exist to prevent.
      {[](Model& m) {
         const Eigen::Index v = first_offset(m);
         m.embedded[2].weights(v, 0) += 3.0, m.embedded[2].weights(v, 1) -= 3.0;
       },
       "embedded surface 2 ('probe') vertex " + std::to_string(first_offset(base)) +
           ": has an offset but weights whose sizes sum to"},
  };
  expect_each_refused_on_load(path, with_surfaces, cases);
}

// Files edited after saving: what only the text can get wrong.
TEST(ModelFileEmbedded, EditedFilesAreRefusedOnLoad) {
  const TempDir dir;
  const std::string path = dir.file("model.vtu");
  const Model m = with_surfaces();
  save_model(m, path);
  const std::string text = file_text(path);
  const int64_t n = m.node_count(), points = point_count(m);
  const std::vector<std::pair<std::string, std::string>> cases = {
      // The '\n' between the first two names made a letter: two names for three surfaces.
      {replace_value(text, "embedded_names", std::string("display_skin").size(), "95"),
       "embedded_names holds 2 name(s) for 3 embedded surface(s)"},
      // The tumour claims one more vertex: the last node would be an embedded vertex.
      {replace_value(text, "embedded_vertex_count", 1, "7"),
       "embedded surface 0 ('display_skin') vertex 0: point " + std::to_string(n - 1) +
           " must have layer -2, mass_kg 0 and fixed 0"},
      {replace_value(text, "embedded_vertex_count", 2, "-6"), "has -6 vertices"},
      {replace_value(text, "mass_kg", -1, "1e-6"), "embedded surface 2 ('probe') vertex 5: point " +
                                                       std::to_string(points - 1) +
                                                       " must have layer -2"},
      {replace_value(text, "embed_corners", 0, "0"),
       "node 0: embed_corners must be -1 and embed_weights 0"},
      {replace_value(text, "embed_offset", 4, "0.5"), "node 1: embed_offset must be 0"},
      // The last cell, the probe's last triangle, claims to be a layer's triangle.
      {replace_value(text, "cell_kind", -1, "0"),
       "VTK cell type 5 with cell_kind 0 does not agree with the expected triangle of embedded "
       "surface 2 (type 5, kind 5)"},
      // Every value still valid: only the checksum tells ('d' of display_skin made 'e').
      {replace_value(text, "embedded_names", 0, "101"), "do not match their checksum"},
  };
  for (const auto& [edited, expected] : cases) {
    write_text(path, edited);
    expect_load_error(path, expected);
  }
  write_text(path, text);
  expect_same_model(m, load_model(path));  // the edits above were the only problem
}

}  // namespace
}  // namespace lamina::io

namespace lamina::io {
namespace {

// with_surfaces() carrying a small portal tree (issue 63): a trunk of two seeds, a branch of two
// after it, the last one beyond the organ (an offset).
Model with_tree() {
  Model m = with_surfaces();
  ModelVesselTree t;
  t.flow.name = "portal_vein";
  t.flow.kind = geometry::VesselTreeKind::kPortal;
  t.flow.roots = 1;
  t.flow.seed_upstream = {-1, 0, 1, 2};
  t.flow.seed_branch = {0, 0, 1, 1};
  t.flow.branch_parent = {-1, 0};
  t.flow.branch_rooted = {1, 1};
  t.flow.branch_length_mm = {4.0, 6.5};
  t.flow.branch_radius_mm = {3.0, 1.5};
  t.flow.branch_territory_ml = {20.0, 11.0};
  t.label = 2;
  const Eigen::RowVector3d c = m.X.colwise().mean();
  Eigen::MatrixX3d V(4, 3);
  V << c, c + Eigen::RowVector3d(2, 0, 0), c + Eigen::RowVector3d(4, 1, 0),
      Eigen::RowVector3d(m.X.col(0).maxCoeff() + 20.0, c.y(), c.z());
  t.seeds = model::embed_points(m, V, t.flow.name, SurfaceRole::kVessel, t.label);
  t.seeds.outside = 0;  // as lamina build leaves it: not kept
  t.in_organ = {1, 1, 1, 0};
  m.trees.push_back(t);
  return m;
}

TEST(ModelFileTrees, TreesRoundTripBitExactlyAsVersionSeven) {
  const TempDir dir;
  const Model m = with_tree();
  ASSERT_GT(model::offset_vertices(m.trees[0].seeds), 0);
  const std::string path = dir.file("model.vtu");
  save_model(m, path);
  expect_same_model(m, load_model(path));
  EXPECT_NE(file_text(path).find("Name=\"lamina_format_version\" NumberOfTuples=\"1\" "
                                 "format=\"ascii\">\n        7\n"),
            std::string::npos);
  // Without trees the file is the version 6 it was, checksum and all.
  Model without = m;
  without.trees.clear();
  EXPECT_EQ(model_fingerprint(without), model_fingerprint(with_surfaces()));
  EXPECT_NE(model_fingerprint(without), model_fingerprint(m));
}

TEST(ModelFileTrees, EditedTreesAreRefusedOnLoad) {
  const TempDir dir;
  const std::string path = dir.file("model.vtu");
  save_model(with_tree(), path);
  const std::string text = file_text(path);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {replace_value(text, "tree_kind", 0, "9"),
       "vessel tree 0 ('portal_vein') has kind 9; expected 1 (portal vein) or 2"},
      {replace_value(text, "seed_upstream", 1, "2"),
       "seed 1: upstream seed 2 does not come before it"},
      {replace_value(text, "seed_branch", 2, "5"), "seed 2: branch 5 is no branch of the tree"},
      {replace_value(text, "seed_corners", 0, "100000"), "seed 0: corner 100000 is not a node"},
      {replace_value(text, "seed_weights", 0, "7"), "seed 0: weights sum to"},
      {replace_value(text, "branch_parent", 1, "4"), "branch 1: parent 4 is no branch"},
      {replace_value(text, "branch_radius_mm", 0, "-1"), "must be finite and >= 0"},
      {replace_value(text, "tree_seed_count", 0, "0"), "has 0 seeds and 2 branches"},
      // Every value still valid: only the checksum tells.
      {replace_value(text, "branch_territory_ml", 0, "21"), "do not match their checksum"},
  };
  for (const auto& [edited, expected] : cases) {
    write_text(path, edited);
    expect_load_error(path, expected);
  }
}

TEST(ModelFileTrees, ATreeWhoseNameWouldNotReadBackIsRefusedOnSave) {
  const TempDir dir;
  Model m = with_tree();
  m.trees[0].flow.name = "portal\nvein";
  const std::string path = dir.file("model.vtu");
  try {
    save_model(m, path);
    ADD_FAILURE() << "saved";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("vessel tree 0 has the name"), std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(fs::exists(path));
}

}  // namespace
}  // namespace lamina::io
