#include "lamina/io/model_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>

#include "lamina/core/error.h"
#include "support/model_file_text.h"
#include "support/temp_dir.h"

namespace lamina::io {
namespace {

using namespace lamina::test;

namespace fs = std::filesystem;

// Two layers: an octahedron (nodes 0-5) around a tetrahedron (nodes 6-9). The coordinates include
// values with long or awkward decimal forms (1/3, 0.1 + 0.2, -0.0, a subnormal) that only survive
// a text round trip if every digit needed is printed.
Model make_test_model() {
  Model m;
  const double third = 1.0 / 3.0;
  m.X.resize(10, 3);
  m.X << 2, 0, 0, -2, 0, 0, 0, 2 + third, 0, 0, -2, 0, 0.1 + 0.2, 0, 2, -0.0, 1e-300, -2,  //
      0.5, 0.5, 0.5, 0.5, -0.5, -0.5, -0.5, 0.5, -0.5, std::numeric_limits<double>::denorm_min(),
      std::nextafter(-0.5, 0.0), 0.5;
  m.layers.resize(2);
  m.layers[0] = {0, 6, {}};
  m.layers[0].F.resize(8, 3);
  m.layers[0].F << 0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5;
  m.layers[1] = {6, 4, {}};
  m.layers[1].F.resize(4, 3);
  m.layers[1].F << 6, 7, 8, 6, 9, 7, 6, 8, 9, 7, 9, 8;
  m.layer_of = {0, 0, 0, 0, 0, 0, 1, 1, 1, 1};
  for (int v = 0; v < 10; ++v) m.mass_kg.push_back(1.06e-6 * (1.0 + v / 7.0));
  m.fixed = {0, 0, 0, 0, 0, 0, 0, 0, 0, 1};
  const auto add_spring = [&](int32_t i, int32_t j, double k, SpringKind kind) {
    m.springs.i.push_back(i);
    m.springs.j.push_back(j);
    m.springs.rest_length_mm.push_back((m.X.row(i) - m.X.row(j)).norm());
    m.springs.stiffness_n_per_m.push_back(k);
    m.springs.kind.push_back(kind);
  };
  add_spring(0, 2, 150.0 / 7.0, SpringKind::kIntraLayer);
  add_spring(2, 4, 0.1, SpringKind::kIntraLayer);
  add_spring(6, 7, 1e5, SpringKind::kIntraLayer);
  add_spring(8, 9, third, SpringKind::kIntraLayer);
  add_spring(0, 6, 42.0, SpringKind::kInterLayer);
  add_spring(3, 9, 2.5e-3, SpringKind::kInterLayer);
  m.rings.locality = 3;
  m.rings.offsets = {0, 1};  // must not be saved
  m.rings.members = {0};
  m.density_kg_per_mm3 = 1.06e-6;
  m.source = "test";
  return m;
}

// One layer, the octahedron of make_test_model(), filled with eight tetrahedra around an
// interior node at its centre: springs are the tetrahedra's edges.
Model make_tet_model() {
  Model m;
  m.X.resize(7, 3);
  m.X << 2, 0, 0, -2, 0, 0, 0, 2, 0, 0, -2, 0, 0, 0, 2, 0, 0, -2, 0.1, -0.2, 0.3;
  m.layers.resize(1);
  m.layers[0] = {0, 6, {}};
  m.layers[0].F.resize(8, 3);
  m.layers[0].F << 0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5;
  m.layer_of = {0, 0, 0, 0, 0, 0, kInteriorNode};
  m.fixed.assign(7, 0);
  m.tets.T.resize(8, 4);
  for (int f = 0; f < 8; ++f)  // the centre lies behind each outward face
    m.tets.T.row(f) << m.layers[0].F(f, 0), m.layers[0].F(f, 2), m.layers[0].F(f, 1), 6;
  m.tets.region.assign(8, 0);
  std::vector<std::pair<int32_t, int32_t>> edges;
  for (int f = 0; f < 8; ++f)
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b)
        edges.emplace_back(std::min(m.tets.T(f, a), m.tets.T(f, b)),
                           std::max(m.tets.T(f, a), m.tets.T(f, b)));
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  for (const auto& [i, j] : edges) {
    m.springs.i.push_back(i);
    m.springs.j.push_back(j);
    m.springs.rest_length_mm.push_back((m.X.row(i) - m.X.row(j)).norm());
    m.springs.stiffness_n_per_m.push_back(3.0);
    m.springs.kind.push_back(j == 6 ? SpringKind::kVolume : SpringKind::kIntraLayer);
  }
  m.mass_kg.assign(7, 1e-6);
  m.rings.locality = 2;
  m.source = "tets";
  return m;
}

TEST(ModelFile, RoundTripIsBitExact) {
  const TempDir dir;
  const Model model = make_test_model();
  const std::string path = dir.file("model.vtu");
  save_model(model, path);
  const Model loaded = load_model(path);
  expect_same_model(model, loaded);
  EXPECT_TRUE(loaded.rings.offsets.empty());
  EXPECT_TRUE(loaded.rings.members.empty());
}

TEST(ModelFile, SourceIsStoredAsBytes) {
  const TempDir dir;
  for (const std::string source : {"", "Leber <&> \"\xc3\xbc\"\nline 2"}) {
    Model model = make_test_model();
    model.source = source;
    save_model(model, dir.file("model.vtu"));
    EXPECT_EQ(load_model(dir.file("model.vtu")).source, source);
  }
}

TEST(ModelFile, FileIsVtkUnstructuredGrid) {
  const TempDir dir;
  save_model(make_test_model(), dir.file("model.vtu"));
  const std::string text = file_text(dir.file("model.vtu"));
  EXPECT_NE(text.find("<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" "
                      "byte_order=\"LittleEndian\" header_type=\"UInt64\">"),
            std::string::npos);
  // 12 triangles and 6 springs.
  EXPECT_NE(text.find("<Piece NumberOfPoints=\"10\" NumberOfCells=\"18\">"), std::string::npos);
  EXPECT_EQ(fs::directory_iterator(dir.path)->path().filename(), "model.vtu");  // no temp left
}

TEST(ModelFile, TruncatedFileThrows) {
  const TempDir dir;
  const std::string path = dir.file("model.vtu");
  save_model(make_test_model(), path);
  const std::string text = file_text(path);
  write_text(path, text.substr(0, text.size() / 2));
  expect_load_error(path, "truncated");
}

TEST(ModelFile, WrongVersionThrows) {
  const TempDir dir;
  const std::string path = dir.file("model.vtu");
  save_model(make_test_model(), path);
  write_text(path, replace_values(file_text(path), "lamina_format_version", "8"));
  expect_load_error(path, "version 8 (this build reads versions 1 to 7)");
  write_text(path, replace_values(file_text(path), "lamina_format_version", "0"));
  expect_load_error(path, "version 0 (this build reads versions 1 to 7)");
}

TEST(ModelFile, TetrahedraRoundTripBitExactly) {
  const TempDir dir;
  const Model model = make_tet_model();
  const std::string path = dir.file("tets.vtu");
  save_model(model, path);
  expect_same_model(model, load_model(path));
  // ParaView sees the volume: VTK_TETRA cells after the triangles and springs.
  const std::string text = file_text(path);
  EXPECT_NE(text.find("<Piece NumberOfPoints=\"7\" NumberOfCells=\"" +
                      std::to_string(8 + model.springs.size() + 8) + "\">"),
            std::string::npos);
}

TEST(ModelFile, VersionOneFilesStillLoad) {
  // A model saved before tetrahedra existed: the same arrays, version 1, no tet_count.
  const TempDir dir;
  const std::string path = dir.file("model.vtu");
  const Model model = make_test_model();
  save_model(model, path);
  std::string text = replace_values(file_text(path), "lamina_format_version", "1");
  const size_t at = text.find("<DataArray type=\"Int64\" Name=\"tet_count\"");
  ASSERT_NE(at, std::string::npos);
  text.erase(at, text.find("</DataArray>", at) + 13 - at);
  write_text(path, text);
  expect_same_model(model, load_model(path));
}

TEST(ModelFile, InvalidTetrahedraAreRejectedOnLoad) {
  const TempDir dir;
  const std::string path = dir.file("tets.vtu");
  const ModelCorruptions cases = {
      {[](Model& m) { std::swap(m.tets.T(2, 0), m.tets.T(2, 1)); },
       "tetrahedron 2: is flat or inverted at rest"},
      {[](Model& m) { m.tets.region[1] = 3; }, "tetrahedron 1: region 3 is not a layer"},
      {[](Model& m) { m.layer_of[6] = 0; },
       "node 6: layer is 0 but the layer ranges put it in layer -1"},
      {[](Model& m) { m.springs.kind.back() = SpringKind::kInterLayer; },
       "an inter-layer spring joins nodes of layers 0 and -1"},
  };
  expect_each_refused_on_load(path, make_tet_model, cases);
}

TEST(ModelFile, FileWithoutVersionIsNotALaminaModel) {
  const TempDir dir;
  const std::string path = dir.file("model.vtu");
  save_model(make_test_model(), path);
  std::string text = file_text(path);
  text.replace(text.find("lamina_format_version"), 6, "other_");
  write_text(path, text);
  expect_load_error(path, "not a Lamina model");
}

TEST(ModelFile, MissingFileThrows) {
  const TempDir dir;
  expect_load_error(dir.file("absent.vtu"), "not found");
}

TEST(ModelFile, WrongNumberOfValuesNamesTheArray) {
  const TempDir dir;
  const std::string path = dir.file("model.vtu");
  save_model(make_test_model(), path);
  const std::string text = file_text(path);
  write_text(path, replace_values(text, "mass_kg", "1 2 3"));
  expect_load_error(path, "mass_kg' has 3 values, expected 10");
  std::string too_many;
  for (int k = 0; k < 19; ++k) too_many += "1 ";
  write_text(path, replace_values(text, "stiffness_n_per_m", too_many));
  expect_load_error(path, "stiffness_n_per_m' has 19 values, expected 18");
  write_text(path, replace_values(text, "connectivity", "0 1 x"));
  expect_load_error(path, "connectivity");
}

TEST(ModelFile, SpringCellTypeMustAgreeWithKind) {
  const TempDir dir;
  const std::string path = dir.file("model.vtu");
  save_model(make_test_model(), path);
  // The 18 cells are 12 triangles then 6 lines; make the first spring claim to be a triangle.
  std::string kinds(12 * 2, ' ');
  for (int c = 0; c < 12; ++c) kinds[2 * c] = '0';
  write_text(path, replace_values(file_text(path), "cell_kind", kinds + "0 1 1 1 2 2"));
  expect_load_error(path, "cell 12: VTK cell type 3 with cell_kind 0 does not agree");
}

// Models that save_model() writes as they are but load_model() must reject.
TEST(ModelFile, InvalidModelsAreRejectedOnLoad) {
  const TempDir dir;
  const std::string path = dir.file("model.vtu");
  const ModelCorruptions cases = {
      {[](Model& m) { m.layers[1].F(0, 0) = 99; }, "uses node 99, outside the layer's nodes"},
      {[](Model& m) { m.layers[1].F(0, 0) = 0; }, "uses node 0, outside the layer's nodes"},
      {[](Model& m) { m.springs.j[0] = 10; }, "spring 0: joins nodes 0 and 10"},
      {[](Model& m) { m.springs.kind[4] = SpringKind::kIntraLayer; },
       "spring 4: an intra-layer spring joins nodes of layers 0 and 1"},
      {[](Model& m) { m.springs.stiffness_n_per_m[1] = -1.0; }, "stiffness_n_per_m is -1"},
      {[](Model& m) { m.springs.rest_length_mm[2] = 0.0; }, "rest_length_mm is 0"},
      {[](Model& m) { m.springs.rest_length_mm[3] = std::nan(""); }, "rest_length_mm is nan"},
      {[](Model& m) { m.mass_kg[5] = 0.0; }, "node 5: mass_kg is 0"},
      {[](Model& m) { m.mass_kg[5] = INFINITY; }, "node 5: mass_kg is inf"},
      {[](Model& m) { m.layers[1].node_count = 3; }, "1 node(s) on no layer but no tetrahedra"},
      {[](Model& m) { m.layers[1].first_node = 5; }, "layer 1 starts at node 5"},
  };
  expect_each_refused_on_load(path, make_test_model, cases);
}

TEST(ModelFile, EmbeddedSurfacesWithoutTetrahedraAreRefusedOnLoad) {
  // A surface follows the corners of tetrahedra; a model joined by links has none.
  const TempDir dir;
  const std::string path = dir.file("model.vtu");
  Model model = make_test_model();
  EmbeddedSurface vessel{.name = "vessel", .label = 2};
  vessel.V.setZero(1, 3);
  vessel.F.resize(0, 3);
  vessel.corners.resize(1, 4);
  vessel.corners << 6, 7, 8, 9;
  vessel.weights.setConstant(1, 4, 0.25);
  model.embedded.push_back(vessel);
  save_model(model, path);
  expect_load_error(path, "embedded surfaces need tetrahedra, and the model has none");
}

TEST(ModelFile, FingerprintOfModelsWithoutEmbeddedSurfacesIsUnchanged) {
  // Checkpoints name their model by it: the values format version 2 gave these models.
  EXPECT_EQ(model_fingerprint(make_test_model()), 2721999170u);
  EXPECT_EQ(model_fingerprint(make_tet_model()), 4102865938u);
}

TEST(ModelFile, SaveIntoMissingDirectoryThrowsOutputError) {
  const TempDir dir;
  try {
    save_model(make_test_model(), dir.file("no/such/dir/model.vtu"));
    ADD_FAILURE() << "save_model wrote into a missing directory";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::kOutput);
  }
}

}  // namespace
}  // namespace lamina::io
