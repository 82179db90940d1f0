// read_vtp (mesh_file.h): a VTK XML PolyData file's points, polygons and triangle strips, in any
// encoding VTK writes (vtk_xml_data.h), as triangles.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <vector>

#include "io/read_file.h"
#include "lamina/core/error.h"
#include "lamina/io/mesh_file.h"
#include "vtk_xml_data.h"

namespace lamina::io {
namespace {

using detail::VtkXmlFile;
using detail::VtkXmlPiece;

int64_t count_attribute(const std::string& path, const VtkXmlPiece& piece, const char* key) {
  const auto it = piece.attributes.find(key);
  if (it == piece.attributes.end()) return 0;
  int64_t n = -1;
  const std::string& t = it->second;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), n);
  if (ec != std::errc() || end != t.data() + t.size() || n < 0 ||
      n > std::numeric_limits<int32_t>::max())
    throw invalid_input(path, std::string("a piece's ") + key + " is '" + t + "'");
  return n;
}

// The cells of `section` (Polys or Strips) as corner lists: VTK writes connectivity and the end
// offset of each cell (files after VTK 9.3 may lead with a 0, read too).
std::vector<std::vector<int64_t>> cells(const VtkXmlFile& file, const VtkXmlPiece& piece,
                                        const std::string& section, int64_t count) {
  std::vector<std::vector<int64_t>> out;
  if (count == 0) return out;
  const std::string& path = file.frame.path;
  const auto offsets_it = piece.arrays.find(section + "/offsets");
  const auto conn_it = piece.arrays.find(section + "/connectivity");
  if (offsets_it == piece.arrays.end() || conn_it == piece.arrays.end())
    throw invalid_input(path, section + " has no connectivity and offsets arrays");
  // The offsets' count is the cells' (or one more, leading with a 0); the connectivity's, the
  // last offset.
  std::vector<int64_t> offsets =
      detail::vtk_integers(file.frame, offsets_it->second, detail::kAnyCount, section + " offsets");
  if (offsets.size() == static_cast<size_t>(count) + 1 && offsets.front() == 0)
    offsets.erase(offsets.begin());
  if (offsets.size() != static_cast<size_t>(count))
    throw invalid_input(path, section + " offsets hold " + std::to_string(offsets.size()) +
                                  " cells where the piece has " + std::to_string(count));
  int64_t begin = 0;
  for (const int64_t end : offsets)
    if (end < begin)
      throw invalid_input(path, section + " offsets are not increasing");
    else
      begin = end;
  const std::vector<int64_t> corners = detail::vtk_integers(
      file.frame, conn_it->second, static_cast<size_t>(offsets.back()), section + " connectivity");
  begin = 0;
  for (const int64_t end : offsets) {
    out.emplace_back(corners.begin() + begin, corners.begin() + end);
    begin = end;
  }
  return out;
}

}  // namespace

SurfaceMesh read_vtp(const std::string& path) {
  const std::string text = detail::read_whole_file(path);
  const VtkXmlFile file = detail::scan_vtk_xml(path, text);
  if (file.type != "PolyData")
    throw invalid_input(path, "is a VTK XML " + (file.type.empty() ? "file" : file.type) +
                                  " file, not PolyData (a surface)");
  if (file.pieces.empty()) throw invalid_input(path, "holds no <Piece>");
  std::vector<double> xyz;
  std::vector<int> tris;
  for (const VtkXmlPiece& piece : file.pieces) {
    const int64_t first = static_cast<int64_t>(xyz.size() / 3);
    const int64_t points = count_attribute(path, piece, "NumberOfPoints");
    const auto it = std::find_if(piece.arrays.begin(), piece.arrays.end(), [](const auto& entry) {
      return entry.first.starts_with("Points/");
    });
    if (points > 0 && it == piece.arrays.end()) throw invalid_input(path, "a piece has no Points");
    if (points > 0) {
      const std::vector<double> p =
          detail::vtk_doubles(file.frame, it->second, 3 * static_cast<size_t>(points), "Points");
      for (const double v : p)
        if (!std::isfinite(v)) throw invalid_input(path, "a point's coordinate is not finite");
      xyz.insert(xyz.end(), p.begin(), p.end());
    }
    auto corner = [&](int64_t c) {
      if (c < 0 || c >= points)
        throw invalid_input(
            path, "a cell names point " + std::to_string(c) + " of " + std::to_string(points));
      return static_cast<int>(first + c);
    };
    for (const auto& poly :
         cells(file, piece, "Polys", count_attribute(path, piece, "NumberOfPolys"))) {
      if (poly.size() < 3)
        throw invalid_input(path, "a polygon has " + std::to_string(poly.size()) + " corners");
      for (size_t k = 2; k < poly.size(); ++k)  // fan from the first corner
        tris.insert(tris.end(), {corner(poly[0]), corner(poly[k - 1]), corner(poly[k])});
    }
    for (const auto& strip :
         cells(file, piece, "Strips", count_attribute(path, piece, "NumberOfStrips"))) {
      for (size_t k = 2; k < strip.size(); ++k) {  // every other triangle turns the other way
        const bool odd = k % 2 == 1;
        tris.insert(tris.end(), {corner(strip[odd ? k - 1 : k - 2]),
                                 corner(strip[odd ? k - 2 : k - 1]), corner(strip[k])});
      }
    }
  }
  if (tris.empty())
    throw invalid_input(path, "holds no polygons or triangle strips (a surface is needed)");
  SurfaceMesh mesh;
  mesh.V = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(
      xyz.data(), static_cast<Eigen::Index>(xyz.size() / 3), 3);
  mesh.F = Eigen::Map<const Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>>(
      tris.data(), static_cast<Eigen::Index>(tris.size() / 3), 3);
  return mesh;
}

}  // namespace lamina::io
