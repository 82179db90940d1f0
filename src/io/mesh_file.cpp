#include "lamina/io/mesh_file.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "lamina/core/atomic_file.h"
#include "lamina/core/error.h"

namespace lamina::io {
namespace {

// Shortest round-trip text, so an OBJ written here reads back to the same doubles.
template <class T>
void append_number(std::string& s, T value) {
  char buf[32];
  s.append(buf, std::to_chars(buf, buf + sizeof buf, value).ptr);
}

// Binary formats are little-endian by definition; build bytes explicitly so the host's byte
// order does not matter.
template <class T>
void append_le(std::string& s, T value) {
  using Bits = std::conditional_t<sizeof(T) == 8, uint64_t,
                                  std::conditional_t<sizeof(T) == 4, uint32_t, uint16_t>>;
  static_assert(sizeof(T) == sizeof(Bits));
  const auto bits = std::bit_cast<Bits>(value);
  for (size_t b = 0; b < sizeof(T); ++b) s += static_cast<char>((bits >> (8 * b)) & 0xff);
}

using Color = std::optional<model::Rgb8>;

std::string obj_text(const SurfaceMesh& mesh, const Color&) {
  std::string s = "# written by Lamina\n";
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v) {
    s += "v";
    for (int c = 0; c < 3; ++c) append_number(s += ' ', mesh.V(v, c));
    s += '\n';
  }
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    s += "f";
    for (int c = 0; c < 3; ++c) append_number(s += ' ', mesh.F(f, c) + 1);
    s += '\n';
  }
  return s;
}

std::string ply_bytes(const SurfaceMesh& mesh, const Color& color) {
  std::string s = "ply\nformat binary_little_endian 1.0\ncomment written by Lamina, units mm\n";
  s += "element vertex " + std::to_string(mesh.V.rows()) +
       "\nproperty double x\nproperty double y\nproperty double z\n";
  if (color) s += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  s += "element face " + std::to_string(mesh.F.rows()) +
       "\nproperty list uchar int vertex_indices\nend_header\n";
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v) {
    for (int c = 0; c < 3; ++c) append_le(s, mesh.V(v, c));
    if (color)
      for (const uint8_t channel : *color) s += static_cast<char>(channel);
  }
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    s += static_cast<char>(3);
    for (int c = 0; c < 3; ++c) append_le(s, static_cast<int32_t>(mesh.F(f, c)));
  }
  return s;
}

std::string vtp_text(const SurfaceMesh& mesh, const Color& color) {
  const auto rows = [](Eigen::Index count, int per_row, const auto& value) {
    std::string s;
    for (Eigen::Index r = 0; r < count; ++r) {
      s += "          ";
      for (int c = 0; c < per_row; ++c) append_number(c == 0 ? s : s += ' ', value(r, c));
      s += '\n';
    }
    return s;
  };
  return "<?xml version=\"1.0\"?>\n"
         "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" "
         "header_type=\"UInt64\">\n"
         "  <PolyData>\n"
         "    <Piece NumberOfPoints=\"" +
         std::to_string(mesh.V.rows()) +
         "\" NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"" +
         std::to_string(mesh.F.rows()) +
         "\">\n"
         "      <Points>\n"
         "        <DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" "
         "format=\"ascii\">\n" +
         rows(mesh.V.rows(), 3, [&](Eigen::Index r, int c) { return mesh.V(r, c); }) +
         "        </DataArray>\n"
         "      </Points>\n" +
         // For ParaView: colour by "color" with Map Scalars off draws the structure's colour.
         (color
              ? "      <PointData>\n"
                "        <DataArray type=\"UInt8\" Name=\"color\" NumberOfComponents=\"3\" "
                "format=\"ascii\">\n" +
                    rows(mesh.V.rows(), 3, [&](Eigen::Index, int c) { return int{(*color)[c]}; }) +
                    "        </DataArray>\n"
                    "      </PointData>\n"
              : std::string()) +
         "      <Polys>\n"
         "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n" +
         rows(mesh.F.rows(), 3, [&](Eigen::Index r, int c) { return int64_t{mesh.F(r, c)}; }) +
         "        </DataArray>\n"
         "        <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n" +
         rows(mesh.F.rows(), 1, [](Eigen::Index r, int) { return int64_t{3 * (r + 1)}; }) +
         "        </DataArray>\n"
         "      </Polys>\n"
         "    </Piece>\n"
         "  </PolyData>\n"
         "</VTKFile>\n";
}

std::string stl_bytes(const SurfaceMesh& mesh, const Color&) {
  // A binary STL header must not start with "solid": readers would take the file for ASCII STL.
  std::string s = "Lamina binary STL, units mm";
  s.resize(80, ' ');
  append_le(s, static_cast<uint32_t>(mesh.F.rows()));
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    const Eigen::RowVector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)),
                             c = mesh.V.row(mesh.F(f, 2));
    // stableNormalized() leaves degenerate triangles with a zero normal instead of NaN.
    const Eigen::RowVector3d n = (b - a).cross(c - a).stableNormalized();
    for (const Eigen::RowVector3d& p : {n, a, b, c})
      for (int k = 0; k < 3; ++k) append_le(s, static_cast<float>(p(k)));
    append_le(s, uint16_t{0});  // attribute byte count
  }
  return s;
}

std::string lowercase_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

// Tokens of one line, split at blanks.
std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> tokens;
  size_t at = 0;
  while ((at = line.find_first_not_of(" \t\r", at)) != std::string_view::npos) {
    const size_t end = std::min(line.size(), line.find_first_of(" \t\r", at));
    tokens.push_back(line.substr(at, end - at));
    at = end;
  }
  return tokens;
}

template <class T>
bool parse_whole(std::string_view text, T& value) {
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  return ec == std::errc() && end == text.data() + text.size();
}

}  // namespace

void write_mesh(const SurfaceMesh& mesh, const std::string& path, const Color& color) {
  const std::string ext = lowercase_extension(path);
  std::string (*encode)(const SurfaceMesh&, const Color&) = nullptr;
  if (ext == ".obj") encode = obj_text;
  if (ext == ".ply") encode = ply_bytes;
  if (ext == ".vtp") encode = vtp_text;
  if (ext == ".stl") encode = stl_bytes;
  if (!encode)
    throw invalid_input(path, "unknown mesh format '" + ext + "' (use .obj, .ply, .vtp or .stl)");
  if (mesh.F.size() > 0 && (mesh.F.minCoeff() < 0 || mesh.F.maxCoeff() >= mesh.V.rows()))
    throw invalid_input(path, "cannot write a mesh whose faces use vertices outside [0, " +
                                  std::to_string(mesh.V.rows()) + ")");
  const std::string bytes = encode(mesh, color);
  write_file_atomically(
      path, [&](std::ostream& out) { out.write(bytes.data(), std::ssize(bytes)); }, true);
}

void write_segments_vtp(const Eigen::MatrixX3d& from, const Eigen::MatrixX3d& to,
                        const std::vector<double>& value, const std::string& value_name,
                        const std::string& path) {
  if (!path.ends_with(".vtp")) throw invalid_input(path, "segments are written as .vtp only");
  const Eigen::Index n = from.rows();
  if (to.rows() != n || static_cast<Eigen::Index>(value.size()) != n)
    throw invalid_input(path, "segments: ends and values differ in number");
  std::string s =
      "<?xml version=\"1.0\"?>\n"
      "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" "
      "header_type=\"UInt64\">\n  <PolyData>\n    <Piece NumberOfPoints=\"" +
      std::to_string(2 * n) + "\" NumberOfVerts=\"0\" NumberOfLines=\"" + std::to_string(n) +
      "\" NumberOfStrips=\"0\" NumberOfPolys=\"0\">\n      <Points>\n"
      "        <DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" "
      "format=\"ascii\">\n";
  for (Eigen::Index r = 0; r < n; ++r)
    for (const Eigen::MatrixX3d* m : {&from, &to}) {
      s += "         ";
      for (int c = 0; c < 3; ++c) append_number(s += ' ', (*m)(r, c));
      s += '\n';
    }
  s += "        </DataArray>\n      </Points>\n      <CellData>\n        <DataArray "
       "type=\"Float64\" Name=\"" +
       value_name + "\" format=\"ascii\">\n";
  for (const double v : value) {
    append_number(s += "          ", v);
    s += '\n';
  }
  s += "        </DataArray>\n      </CellData>\n      <Lines>\n        <DataArray "
       "type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n";
  for (Eigen::Index r = 0; r < n; ++r) s += fmt::format("          {} {}\n", 2 * r, 2 * r + 1);
  s += "        </DataArray>\n        <DataArray type=\"Int64\" Name=\"offsets\" "
       "format=\"ascii\">\n";
  for (Eigen::Index r = 0; r < n; ++r) s += fmt::format("          {}\n", 2 * (r + 1));
  s += "        </DataArray>\n      </Lines>\n    </Piece>\n  </PolyData>\n</VTKFile>\n";
  write_file_atomically(path, [&](std::ostream& out) { out << s; });
}

SurfaceMesh read_obj(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw invalid_input(path, std::filesystem::exists(path) ? "cannot open the file for reading"
                                                            : "file not found");
  std::vector<std::array<double, 3>> vertices;
  std::vector<std::array<int64_t, 3>> triangles;
  std::vector<int64_t> triangle_line;  // to name the line of a bad index once all v are known
  std::string line;
  for (int64_t number = 1; std::getline(in, line); ++number) {
    const std::vector<std::string_view> tokens = split(line);
    if (tokens.empty()) continue;
    const std::string where = "line " + std::to_string(number) + ": ";
    if (tokens[0] == "v") {
      std::array<double, 3> p{};
      bool ok = tokens.size() >= 4;
      for (int c = 0; ok && c < 3; ++c)
        ok = parse_whole(tokens[c + 1], p[c]) && std::isfinite(p[c]);
      if (!ok) throw invalid_input(path, where + "expected 'v x y z' with three finite numbers");
      vertices.push_back(p);
    } else if (tokens[0] == "f") {
      if (tokens.size() < 4) throw invalid_input(path, where + "a face needs at least 3 vertices");
      std::vector<int64_t> corners;
      for (size_t k = 1; k < tokens.size(); ++k) {
        // Only the vertex index matters: "i", "i/t", "i/t/n" and "i//n" all start with it.
        int64_t index = 0;
        if (!parse_whole(tokens[k].substr(0, tokens[k].find('/')), index) || index == 0)
          throw invalid_input(path, where + "bad face index '" + std::string(tokens[k]) + "'");
        // Negative indices count back from the newest vertex, so resolve them now.
        if (index < -std::ssize(vertices))
          throw invalid_input(path, where + "relative index " + std::to_string(index) +
                                        " reaches before the first vertex");
        corners.push_back(index < 0 ? static_cast<int64_t>(vertices.size()) + index : index - 1);
      }
      // A fan from the first corner triangulates the convex polygons OBJ files hold.
      for (size_t k = 1; k + 1 < corners.size(); ++k) {
        triangles.push_back({corners[0], corners[k], corners[k + 1]});
        triangle_line.push_back(number);
      }
    }
  }
  if (triangles.empty()) throw invalid_input(path, "no faces (f lines) found");

  SurfaceMesh mesh;
  mesh.V.resize(std::ssize(vertices), 3);
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v)
    for (int c = 0; c < 3; ++c) mesh.V(v, c) = vertices[v][c];
  mesh.F.resize(std::ssize(triangles), 3);
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int64_t index = triangles[f][c];
      if (index < 0 || index >= mesh.V.rows())
        throw invalid_input(path, "line " + std::to_string(triangle_line[f]) +
                                      ": face uses vertex " + std::to_string(index + 1) +
                                      " but the file has " + std::to_string(mesh.V.rows()) +
                                      " vertices");
      mesh.F(f, c) = static_cast<int>(index);
    }
  return mesh;
}

}  // namespace lamina::io
