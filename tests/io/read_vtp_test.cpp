// read_vtp on files VTK itself wrote (tests/io/vtp, scripts/make_vtp_fixtures.py: VTK 9.1's
// vtkXMLPolyDataWriter in every encoding it has), and on those files broken as files break.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <string>

#include "lamina/core/error.h"
#include "lamina/io/mesh_file.h"
#include "support/temp_dir.h"
#include "support/test_paths.h"

namespace lamina::io {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::string fixture(const std::string& name) {
  return test::source_path("tests/io/vtp/" + name + ".vtp").string();
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const fs::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

// The sheet every fixture holds: 9 x 7 points in the plane x = 30 mm, y and z in [-250, 250].
TEST(ReadVtp, EveryEncodingVtkWritesGivesTheSameSheet) {
  const SurfaceMesh ascii = read_vtp(fixture("ascii"));
  ASSERT_EQ(ascii.V.rows(), 63);
  ASSERT_EQ(ascii.F.rows(), 96);
  const Eigen::Vector3d first_normal =
      (ascii.V.row(ascii.F(0, 1)) - ascii.V.row(ascii.F(0, 0)))
          .cross(ascii.V.row(ascii.F(0, 2)) - ascii.V.row(ascii.F(0, 0)))
          .transpose();
  for (const char* name : {"ascii", "binary", "binary_zlib", "appended", "appended_zlib_uint64",
                           "raw", "raw_zlib", "raw_big_endian", "strips", "default"}) {
    SCOPED_TRACE(name);
    const SurfaceMesh m = read_vtp(fixture(name));
    ASSERT_EQ(m.V.rows(), 63);
    ASSERT_EQ(m.F.rows(), 96);
    EXPECT_LT((m.V - ascii.V).cwiseAbs().maxCoeff(), 1e-4);  // Float32 and Float64 points
    EXPECT_EQ(m.V.col(0).minCoeff(), 30.0);
    EXPECT_EQ(m.V.col(0).maxCoeff(), 30.0);
    // The triangles tile the 500 x 500 mm square once, every one turned as the first.
    double area = 0.0;
    for (Eigen::Index t = 0; t < m.F.rows(); ++t) {
      ASSERT_GE(m.F.row(t).minCoeff(), 0);
      ASSERT_LT(m.F.row(t).maxCoeff(), 63);
      const Eigen::Vector3d n = (m.V.row(m.F(t, 1)) - m.V.row(m.F(t, 0)))
                                    .cross(m.V.row(m.F(t, 2)) - m.V.row(m.F(t, 0)))
                                    .transpose();
      EXPECT_GT(n.dot(first_normal), 0.0) << "triangle " << t << " is turned over";
      area += 0.5 * n.norm();
    }
    EXPECT_NEAR(area, 500.0 * 500.0, 1e-3);
  }
}

struct Broken {
  std::string from;     // fixture
  std::string after;    // where to look from: the text after this (empty: the file's start)
  std::string find;     // replaced ...
  std::string replace;  // ... by this; find "cut": the file halved; "tail": the last data bytes
  std::string says;
};

TEST(ReadVtp, RefusesBrokenFilesNamingThemAndTheProblem) {
  const test::TempDir dir;
  const Broken cases[] = {
      {"raw_zlib", "", "cut", "", "cut off"},
      {"binary", "Name=\"Points\"", "9AIA", "9*IA", "base64"},
      {"ascii", "", "type=\"PolyData\"", "type=\"UnstructuredGrid\"", "not PolyData"},
      {"binary_zlib", "", "vtkZLibDataCompressor", "vtkLZ4DataCompressor", "vtkLZ4DataCompressor"},
      {"ascii", "", "NumberOfPolys=\"96\"", "NumberOfPolys=\"97\"", "Polys offsets hold 96"},
      {"ascii", "", "NumberOfPoints=\"63\"", "NumberOfPoints=\"62\"", "more than the 186 values"},
      {"ascii", "", "0 1 9 10 9 1", "0 1 99 10 9 1", "names point 99 of 63"},
      {"ascii", "", "30 -250 -250 30 -187.5", "nan -250 -250 30 -187.5", "not finite"},
      {"ascii", "", "NumberOfPolys=\"96\"", "NumberOfPolys=\"0\"", "no polygons"},
      {"binary", "", "header_type=\"UInt32\"", "header_type=\"UInt16\"", "UInt16"},
      {"raw_zlib", "", "tail", "", "zlib data is corrupt"},
      {"appended", "Name=\"Points\"", "offset=\"1696\"", "offset=\"999999\"", "offset"},
  };
  for (const Broken& c : cases) {
    SCOPED_TRACE(c.from + ": " + c.after + " " + c.find + " -> " + c.replace);
    std::string bytes = read_bytes(fixture(c.from));
    if (c.find == "cut") {
      bytes.resize(bytes.size() / 2);
    } else if (c.find == "tail") {  // the last compressed block's end, so its checksum fails
      const size_t end = bytes.rfind("</AppendedData>");
      ASSERT_NE(end, std::string::npos);
      bytes.replace(end - 16, 8, "xxxxxxxx");
    } else {
      const size_t at = bytes.find(c.find, c.after.empty() ? 0 : bytes.find(c.after));
      ASSERT_NE(at, std::string::npos);
      bytes.replace(at, c.find.size(), c.replace);
    }
    const fs::path path = dir.path / "broken.vtp";
    write_bytes(path, bytes);
    try {
      read_vtp(path.string());
      ADD_FAILURE() << "read without complaint";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::kInvalidInput);
      EXPECT_THAT(e.what(), HasSubstr(path.string()));
      EXPECT_THAT(e.what(), HasSubstr(c.says));
    }
  }
}

}  // namespace
}  // namespace lamina::io
