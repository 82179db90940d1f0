// read_resection_surface (resection_input.h): 3D Slicer markups (nlohmann::json) and surface
// files (our OBJ and VTP readers; CGAL's polygon soup reader for PLY, STL and OFF).
#include "lamina/io/resection_input.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/IO/polygon_soup_io.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cctype>
#include <nlohmann/json.hpp>
#include <vector>

#include "io/read_file.h"
#include "lamina/core/error.h"
#include "lamina/io/mesh_file.h"

namespace lamina::io {
namespace {

using json = nlohmann::json;

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// A 3-vector of numbers at `key` of `object`, turned from RAS to LPS when `ras`.
Eigen::Vector3d vec3(const json& object, const char* key, bool ras, const std::string& path,
                     const std::string& where) {
  const auto it = object.find(key);
  if (it == object.end() || !it->is_array() || it->size() != 3 ||
      !std::all_of(it->begin(), it->end(), [](const json& v) { return v.is_number(); }))
    throw invalid_input(path, where + "." + key + " is not three numbers");
  Eigen::Vector3d v((*it)[0].get<double>(), (*it)[1].get<double>(), (*it)[2].get<double>());
  if (ras) v.head<2>() = -v.head<2>();
  return v;
}

std::vector<Eigen::Vector3d> control_points(const json& markup, bool ras, const std::string& path) {
  std::vector<Eigen::Vector3d> points;
  const auto it = markup.find("controlPoints");
  if (it == markup.end() || !it->is_array())
    throw invalid_input(path, "markups[0] has no controlPoints array");
  for (size_t i = 0; i < it->size(); ++i) {
    const json& p = (*it)[i];
    if (!p.is_object())
      throw invalid_input(path, "controlPoints[" + std::to_string(i) + "] is not an object");
    points.push_back(vec3(p, "position", ras, path, "controlPoints[" + std::to_string(i) + "]"));
  }
  return points;
}

geometry::ResectionSurface read_plane(const json& m, bool ras, const std::string& path) {
  // Slicer 5 writes the plane's centre and normal; older files, or ones written by hand, only
  // its control points (one with the baseToNode axes, or three).
  if (m.contains("center") && m.contains("normal")) {
    try {
      return geometry::plane_surface(vec3(m, "center", ras, path, "markups[0]"),
                                     vec3(m, "normal", ras, path, "markups[0]"));
    } catch (const Error& e) {
      throw invalid_input(path, std::string("the plane's ") + e.what());
    }
  }
  const std::vector<Eigen::Vector3d> p = control_points(m, ras, path);
  if (p.size() >= 3) {
    const Eigen::Vector3d n = (p[1] - p[0]).cross(p[2] - p[0]);
    if (!(n.norm() > 0.0))
      throw invalid_input(path, "the plane's three control points lie along one line");
    return geometry::plane_surface(p[0], n);
  }
  if (p.size() == 1 && m.contains("baseToNode")) {
    const json& b = m["baseToNode"];
    if (!b.is_array() || b.size() != 16 ||
        !std::all_of(b.begin(), b.end(), [](const json& v) { return v.is_number(); }))
      throw invalid_input(path, "markups[0].baseToNode is not 16 numbers");
    // Row-major 4x4; its third column is the plane's normal.
    Eigen::Vector3d n(b[2].get<double>(), b[6].get<double>(), b[10].get<double>());
    if (ras) n.head<2>() = -n.head<2>();
    if (!(n.norm() > 0.0)) throw invalid_input(path, "the plane's normal has zero length");
    return geometry::plane_surface(p[0], n);
  }
  throw invalid_input(path,
                      "the plane has no normal: give \"center\" and \"normal\", one control point "
                      "with \"baseToNode\", or three control points");
}

geometry::ResectionSurface read_markups(const std::string& path) {
  json root;
  try {
    root = json::parse(detail::read_whole_file(path));
  } catch (const json::exception& e) {
    throw invalid_input(path, std::string("not valid JSON: ") + e.what());
  }
  if (!root.is_object() || !root.contains("markups") || !root["markups"].is_array())
    throw invalid_input(path, "not a 3D Slicer markups file (no \"markups\" array)");
  const json& all = root["markups"];
  if (all.size() != 1)
    throw invalid_input(path, "holds " + std::to_string(all.size()) +
                                  " markups; give a file with one plane or one closed curve");
  const json& m = all[0];
  if (!m.is_object() || !m.contains("type") || !m["type"].is_string())
    throw invalid_input(path, "markups[0] has no type");
  const std::string type = m["type"].get<std::string>();
  std::string system = "LPS";
  if (m.contains("coordinateSystem") && m["coordinateSystem"].is_string())
    system = m["coordinateSystem"].get<std::string>();
  if (system != "LPS" && system != "RAS")
    throw invalid_input(path, "coordinateSystem '" + system + "' is neither LPS nor RAS");
  const bool ras = system == "RAS";
  if (type == "Plane") return read_plane(m, ras, path);
  if (type == "ClosedCurve")
    return geometry::closed_curve_surface(control_points(m, ras, path), path);
  if (type == "Curve")
    throw invalid_input(path,
                        "the curve is not closed (type Curve): draw a closed curve, or a plane");
  throw invalid_input(
      path, "a markups " + type + " is not a resection surface: give a Plane or a ClosedCurve");
}

geometry::ResectionSurface read_soup(const std::string& path) {
  using Point = CGAL::Exact_predicates_inexact_constructions_kernel::Point_3;
  std::vector<Point> points;
  std::vector<std::vector<size_t>> polygons;
  if (!std::filesystem::exists(path)) throw invalid_input(path, "file not found");
  bool ok = false;
  try {
    ok = CGAL::IO::read_polygon_soup(path, points, polygons);
  } catch (const std::exception& e) {
    throw invalid_input(path, std::string("cannot read the surface: ") + e.what());
  }
  if (!ok) throw invalid_input(path, "cannot read the surface (malformed file)");
  Eigen::MatrixX3d V(static_cast<Eigen::Index>(points.size()), 3);
  for (size_t i = 0; i < points.size(); ++i)
    V.row(static_cast<Eigen::Index>(i)) << points[i].x(), points[i].y(), points[i].z();
  std::vector<std::array<int, 3>> tris;
  for (const auto& poly : polygons) {
    for (const size_t c : poly)
      if (c >= points.size())
        throw invalid_input(path, "a face names a vertex the file does not have");
    for (size_t c = 2; c < poly.size(); ++c)  // fan from the first corner
      tris.push_back(
          {static_cast<int>(poly[0]), static_cast<int>(poly[c - 1]), static_cast<int>(poly[c])});
  }
  Eigen::MatrixX3i F(static_cast<Eigen::Index>(tris.size()), 3);
  for (size_t t = 0; t < tris.size(); ++t)
    F.row(static_cast<Eigen::Index>(t)) << tris[t][0], tris[t][1], tris[t][2];
  return geometry::mesh_surface(V, F, path);
}

}  // namespace

geometry::ResectionSurface read_resection_surface(const std::string& path) {
  const std::string name = lower(path);
  if (name.ends_with(".json")) return read_markups(path);
  if (name.ends_with(".obj")) {
    const SurfaceMesh mesh = read_obj(path);
    return geometry::mesh_surface(mesh.V, mesh.F, path);
  }
  if (name.ends_with(".vtp")) {
    const SurfaceMesh mesh = read_vtp(path);
    return geometry::mesh_surface(mesh.V, mesh.F, path);
  }
  if (name.ends_with(".ply") || name.ends_with(".stl") || name.ends_with(".off"))
    return read_soup(path);
  throw invalid_input(path,
                      "unsupported resection surface (use .mrk.json, .vtp, .obj, .ply, .stl or "
                      ".off; 3D Slicer saves a model as .vtp, .ply or .obj, not as legacy .vtk)");
}

}  // namespace lamina::io
