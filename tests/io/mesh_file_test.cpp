#include "lamina/io/mesh_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "lamina/core/error.h"
#include "support/temp_dir.h"

namespace lamina::io {
namespace {

using lamina::test::TempDir;

namespace fs = std::filesystem;

// An octahedron, outward winding, with coordinates that need all 17 significant digits.
SurfaceMesh make_octahedron() {
  SurfaceMesh mesh;
  mesh.V.resize(6, 3);
  mesh.V << 1.0 / 3.0, 0, 0, -1, 0, 0, 0, 0.1 + 0.2, 0, 0, -1, 0, 0, 0, 1e-7, 0, 0, -2.5;
  mesh.F.resize(8, 3);
  mesh.F << 0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5;
  return mesh;
}

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

void expect_invalid_input(const std::string& path, const std::string& expected) {
  try {
    read_obj(path);
    ADD_FAILURE() << "read_obj accepted " << path;
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_EQ(e.kind(), ErrorKind::kInvalidInput) << message;
    EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    EXPECT_NE(message.find(expected), std::string::npos) << message;
  }
}

TEST(MeshFile, ObjRoundTripIsExact) {
  const TempDir dir;
  const SurfaceMesh mesh = make_octahedron();
  write_mesh(mesh, dir.file("octahedron.obj"));
  const SurfaceMesh read = read_obj(dir.file("octahedron.obj"));
  EXPECT_EQ(read.V, mesh.V);  // exact: doubles are written in shortest round-trip form
  EXPECT_EQ(read.F, mesh.F);
}

TEST(MeshFile, ExtensionIsCaseInsensitive) {
  const TempDir dir;
  write_mesh(make_octahedron(), dir.file("octahedron.OBJ"));
  EXPECT_EQ(read_obj(dir.file("octahedron.OBJ")).F, make_octahedron().F);
}

TEST(MeshFile, PlyHeaderAndSize) {
  const TempDir dir;
  write_mesh(make_octahedron(), dir.file("octahedron.ply"));
  const std::string bytes = read_text(dir.file("octahedron.ply"));
  const size_t header_end = bytes.find("end_header\n");
  ASSERT_NE(header_end, std::string::npos);
  const std::string header = bytes.substr(0, header_end);
  EXPECT_EQ(header.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
  EXPECT_NE(header.find("element vertex 6\n"), std::string::npos);
  EXPECT_NE(header.find("element face 8\n"), std::string::npos);
  EXPECT_NE(header.find("property list uchar int vertex_indices\n"), std::string::npos);
  // 6 vertices of 3 float64, then 8 faces of a count byte and 3 int32.
  EXPECT_EQ(bytes.size(), header_end + 11 + 6 * 24 + 8 * 13);
  double x = 0;
  std::memcpy(&x, bytes.data() + header_end + 11, sizeof x);
  EXPECT_EQ(x, 1.0 / 3.0);
}

TEST(MeshFile, StlSizeAndCount) {
  const TempDir dir;
  write_mesh(make_octahedron(), dir.file("octahedron.stl"));
  const std::string bytes = read_text(dir.file("octahedron.stl"));
  ASSERT_EQ(bytes.size(), 84u + 50u * 8u);
  EXPECT_NE(bytes.rfind("solid", 0), 0u);  // would make readers take it for ASCII STL
  uint32_t count = 0;
  std::memcpy(&count, bytes.data() + 80, sizeof count);
  EXPECT_EQ(count, 8u);
  // Face 0 joins +x, +y and +z: its outward normal is (1, 1, 1) direction, unit length.
  float normal[3];
  std::memcpy(normal, bytes.data() + 84, sizeof normal);
  EXPECT_GT(normal[0], 0.0f);
  EXPECT_GT(normal[1], 0.0f);
  EXPECT_GT(normal[2], 0.0f);
  EXPECT_NEAR(normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2], 1.0, 1e-6);
}

TEST(MeshFile, VtpIsPolyData) {
  const TempDir dir;
  write_mesh(make_octahedron(), dir.file("octahedron.vtp"));
  const std::string text = read_text(dir.file("octahedron.vtp"));
  EXPECT_NE(text.find("<VTKFile type=\"PolyData\""), std::string::npos);
  EXPECT_NE(text.find("NumberOfPoints=\"6\""), std::string::npos);
  EXPECT_NE(text.find("NumberOfPolys=\"8\""), std::string::npos);
  EXPECT_NE(text.find("<Polys>"), std::string::npos);
  EXPECT_NE(text.find("</VTKFile>"), std::string::npos);
}

TEST(MeshFile, UnknownExtensionThrowsAndWritesNothing) {
  const TempDir dir;
  const std::string path = dir.file("octahedron.xyz");
  try {
    write_mesh(make_octahedron(), path);
    ADD_FAILURE() << "write_mesh accepted .xyz";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::kInvalidInput);
    EXPECT_EQ(std::string(e.what()),
              path + ": unknown mesh format '.xyz' (use .obj, .ply, .vtp or .stl)");
  }
  EXPECT_TRUE(dir.empty());
}

TEST(MeshFile, MissingDirectoryThrowsOutputError) {
  const TempDir dir;
  try {
    write_mesh(make_octahedron(), dir.file("no/such/dir/octahedron.stl"));
    ADD_FAILURE() << "write_mesh wrote into a missing directory";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::kOutput);
  }
  EXPECT_TRUE(dir.empty());
}

TEST(MeshFile, ReadObjHandlesIndexFormsAndPolygons) {
  const TempDir dir;
  const std::string path = dir.file("quad.obj");
  write_text(path,
             "# a unit square as a quad, then one triangle with relative indices\n"
             "o square\nv 0 0 0\nv 1 0 0\r\nv 1 1 0\nv 0 1 0 1.0\n"
             "vt 0 0\nvn 0 0 1\ns off\n"
             "f 1/1/1 2/1/1 3/1/1 4/1/1\n"
             "v 0.5 0.5 1\n"
             "f\t-5//1 -4//1 -1//1\n"
             "f 2/1 3/1 5/1\n");
  const SurfaceMesh mesh = read_obj(path);
  ASSERT_EQ(mesh.V.rows(), 5);
  EXPECT_EQ(mesh.V(4, 2), 1.0);
  Eigen::MatrixX3i F(4, 3);
  F << 0, 1, 2, 0, 2, 3, 0, 1, 4, 1, 2, 4;
  EXPECT_EQ(mesh.F, F);
}

TEST(MeshFile, ReadObjErrors) {
  const TempDir dir;
  expect_invalid_input(dir.file("absent.obj"), "file not found");
  write_text(dir.file("bad_index.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
  expect_invalid_input(dir.file("bad_index.obj"), "line 4: face uses vertex 9");
  write_text(dir.file("zero_index.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
  expect_invalid_input(dir.file("zero_index.obj"), "line 4: bad face index '0'");
  write_text(dir.file("relative.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n");
  expect_invalid_input(dir.file("relative.obj"), "line 4: relative index -4");
  write_text(dir.file("no_faces.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
  expect_invalid_input(dir.file("no_faces.obj"), "no faces");
  write_text(dir.file("bad_vertex.obj"), "v 0 zero 0\n");
  expect_invalid_input(dir.file("bad_vertex.obj"), "line 1: expected 'v x y z'");
}

}  // namespace
}  // namespace lamina::io
