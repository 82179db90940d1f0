// A surface split along another with CGAL's corefinement (PMP::split). CGAL keeps the vertices
// it does not touch (Surface_mesh appends the ones it makes), so their indices tell their origin.
#include "lamina/geometry/split_surface.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/clip.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_degeneracies.h>
#include <CGAL/Surface_mesh.h>

#include <array>
#include <map>
#include <string>

#include "cgal_soup.h"
#include "lamina/core/error.h"

namespace lamina::geometry {
namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
using cgal::Point, cgal::Mesh;

// The mesh as CGAL's; `origin` gets, per CGAL vertex, the input vertex it is (a vertex where two
// fans meet is split in two by orient_polygon_soup, both keeping its origin).
Mesh to_mesh(const SurfaceMesh& in, std::vector<int32_t>& origin) {
  std::vector<Point> points;
  std::vector<std::array<size_t, 3>> faces;
  cgal::to_soup(in, points, faces);
  const size_t n = points.size();
  if (!PMP::is_polygon_soup_a_polygon_mesh(faces)) {
    // Duplicates the pinched vertices (appended), keeping each face's winding where it can.
    PMP::orient_polygon_soup(points, faces);
    if (!PMP::is_polygon_soup_a_polygon_mesh(faces)) {
      std::map<std::pair<size_t, size_t>, int> use;
      int degenerate = 0, shared = 0;
      for (const auto& f : faces) {
        degenerate += f[0] == f[1] || f[1] == f[2] || f[0] == f[2];
        for (int k = 0; k < 3; ++k)
          ++use[{std::min(f[k], f[(k + 1) % 3]), std::max(f[k], f[(k + 1) % 3])}];
      }
      for (const auto& [e, u] : use) shared += u > 2;
      throw invalid_input("split", "the surface's triangles near the cut are not a manifold (" +
                                       std::to_string(degenerate) + " degenerate, " +
                                       std::to_string(shared) + " edges in 3 or more)");
    }
  }
  origin.resize(points.size());
  for (size_t v = 0; v < n; ++v) origin[v] = static_cast<int32_t>(v);
  if (points.size() > n) {  // the duplicated ones' origins, by position (rarely: pinched fans)
    std::map<std::array<double, 3>, int32_t> at;
    for (size_t v = 0; v < n; ++v)
      at.emplace(std::array{points[v].x(), points[v].y(), points[v].z()}, static_cast<int32_t>(v));
    for (size_t v = n; v < points.size(); ++v)
      origin[v] = at.at(std::array{points[v].x(), points[v].y(), points[v].z()});
  }
  Mesh mesh;
  PMP::polygon_soup_to_polygon_mesh(points, faces, mesh);
  return mesh;
}

}  // namespace

SplitSurface split_surface(const SurfaceMesh& mesh, const SurfaceMesh& splitter) {
  std::vector<int32_t> origin, unused;
  Mesh tm = to_mesh(mesh, origin);
  Mesh sm = to_mesh(splitter, unused);
  try {
    PMP::split(tm, sm, CGAL::parameters::default_values(), CGAL::parameters::do_not_modify(true));
    // Where the surface already had a vertex on the splitter (to rounding: a cut along an
    // earlier one), the corefinement can leave triangles of three collinear points.
    PMP::remove_degenerate_faces(tm);
  } catch (const std::exception& e) {
    throw invalid_input("split", std::string("CGAL could not split the surface: ") + e.what());
  }
  SplitSurface out;
  std::vector<int32_t> id(tm.number_of_vertices() + tm.number_of_removed_vertices(), -1);
  out.V.resize(static_cast<Eigen::Index>(tm.number_of_vertices()), 3);
  out.origin.reserve(tm.number_of_vertices());
  int32_t n = 0;
  for (auto v : tm.vertices()) {
    const Point& p = tm.point(v);
    out.V.row(n) << p.x(), p.y(), p.z();
    out.origin.push_back(v.idx() < origin.size() ? origin[v.idx()] : -1);
    id[v.idx()] = n++;
  }
  out.F.resize(static_cast<Eigen::Index>(tm.number_of_faces()), 3);
  Eigen::Index f = 0;
  for (auto face : tm.faces()) {
    int c = 0;
    for (auto v : CGAL::vertices_around_face(tm.halfedge(face), tm)) out.F(f, c++) = id[v.idx()];
    ++f;
  }
  return out;
}

}  // namespace lamina::geometry
