// The only translation unit that sees CGAL (it compiles slowly and needs ~1.3 GB of RAM).
#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/connected_components.h>
#include <CGAL/Polygon_mesh_processing/intersection.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Side_of_triangle_mesh.h>
#include <CGAL/Surface_mesh.h>

#include <array>
#include <cmath>

#include "cgal_soup.h"
#include "lamina/core/error.h"
#include "lamina/geometry/mesh_measures.h"
#include "lamina/geometry/remesh.h"

namespace lamina::geometry {
namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
using cgal::K, cgal::Point, cgal::Mesh;

// Builds a CGAL mesh from our arrays via a repaired, oriented polygon soup, so that inputs
// with duplicate points or non-manifold vertices (possible in isosurfaces) still convert.
Mesh to_cgal(const SurfaceMesh& in, bool repair) {
  std::vector<Point> points;
  std::vector<std::array<size_t, 3>> faces;
  cgal::to_soup(in, points, faces);
  if (repair) {
    PMP::repair_polygon_soup(points, faces);
    PMP::orient_polygon_soup(points, faces);
  }
  Mesh mesh;
  PMP::polygon_soup_to_polygon_mesh(points, faces, mesh);
  return mesh;
}

SurfaceMesh from_cgal(const Mesh& mesh) {
  SurfaceMesh out;
  std::vector<int> id(mesh.num_vertices() + mesh.number_of_removed_vertices(), -1);
  out.V.resize(static_cast<Eigen::Index>(mesh.number_of_vertices()), 3);
  int n = 0;
  for (auto v : mesh.vertices()) {
    const Point& p = mesh.point(v);
    out.V.row(n) << p.x(), p.y(), p.z();
    id[v.idx()] = n++;
  }
  out.F.resize(static_cast<Eigen::Index>(mesh.number_of_faces()), 3);
  int f = 0;
  for (auto face : mesh.faces()) {
    int c = 0;
    for (auto v : CGAL::vertices_around_face(mesh.halfedge(face), mesh))
      out.F(f, c++) = id[v.idx()];
    ++f;
  }
  return out;
}

}  // namespace

SurfaceMesh remesh(const SurfaceMesh& input, const RemeshOptions& options) {
  if (!(options.target_edge_mm > 0.0))
    throw Error(ErrorKind::kInternal, "remesh: target edge length must be positive");
  if (input.F.rows() == 0) return input;
  const bool outward = enclosed_volume(input) >= 0.0;
  Mesh mesh = to_cgal(input, /*repair=*/true);
  PMP::isotropic_remeshing(faces(mesh), options.target_edge_mm, mesh,
                           PMP::parameters::number_of_iterations(options.iterations)
                               .protect_constraints(false)
                               .number_of_relaxation_steps(3));
  mesh.collect_garbage();
  SurfaceMesh out = from_cgal(mesh);
  // orient_polygon_soup fixes consistency, not the global sign: restore the input's.
  if ((enclosed_volume(out) >= 0.0) != outward) out.F.col(1).swap(out.F.col(2));
  return out;
}

bool self_intersects(const SurfaceMesh& mesh) {
  if (mesh.F.rows() == 0) return false;
  const Mesh m = to_cgal(mesh, /*repair=*/false);
  if (m.number_of_faces() != static_cast<size_t>(mesh.F.rows()))
    return true;  // not a valid surface
  return PMP::does_self_intersect(m);
}

SelfIntersection find_self_intersection(const SurfaceMesh& mesh) {
  SelfIntersection out;
  if (mesh.F.rows() == 0) return out;
  const Mesh m = to_cgal(mesh, /*repair=*/false);
  if (m.number_of_faces() != static_cast<size_t>(mesh.F.rows())) return out;
  std::vector<std::pair<Mesh::Face_index, Mesh::Face_index>> pairs;
  PMP::self_intersections(m, std::back_inserter(pairs));
  // to_cgal() keeps the faces in order, so a CGAL face index is a row of F.
  for (const auto& [a, b] : pairs)
    for (const auto f : {static_cast<Eigen::Index>(a.idx()), static_cast<Eigen::Index>(b.idx())})
      for (int c = 0; c < 3; ++c) out.where += mesh.V.row(mesh.F(f, c)).transpose() / 6.0;
  out.pairs = static_cast<int64_t>(pairs.size());
  if (out.pairs > 0) out.where /= static_cast<double>(out.pairs);
  return out;
}

SurfaceDistance surface_distance(const SurfaceMesh& from, const SurfaceMesh& to) {
  SurfaceDistance d;
  if (from.V.rows() == 0 || to.F.rows() == 0) return d;
  const Mesh target = to_cgal(to, /*repair=*/false);
  using Primitive = CGAL::AABB_face_graph_triangle_primitive<Mesh>;
  using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, Primitive>>;
  Tree tree(faces(target).first, faces(target).second, target);
  tree.accelerate_distance_queries();
  double sum = 0.0, sum2 = 0.0;
  for (Eigen::Index v = 0; v < from.V.rows(); ++v) {
    const double dist =
        std::sqrt(tree.squared_distance(Point(from.V(v, 0), from.V(v, 1), from.V(v, 2))));
    sum += dist;
    sum2 += dist * dist;
    d.max_mm = std::max(d.max_mm, dist);
  }
  const double n = static_cast<double>(from.V.rows());
  d.mean_mm = sum / n;
  d.rms_mm = std::sqrt(sum2 / n);
  return d;
}

Nesting check_nesting(const SurfaceMesh& outer, const SurfaceMesh& inner) {
  Nesting result;
  if (outer.F.rows() == 0 || inner.F.rows() == 0) return result;
  const Mesh out_mesh = to_cgal(outer, /*repair=*/false);
  const Mesh in_mesh = to_cgal(inner, /*repair=*/false);
  using Primitive = CGAL::AABB_face_graph_triangle_primitive<Mesh>;
  using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, Primitive>>;
  Tree tree(faces(out_mesh).first, faces(out_mesh).second, out_mesh);
  tree.accelerate_distance_queries();
  CGAL::Side_of_triangle_mesh<Mesh, K> side(tree);
  result.all_vertices_inside = true;
  result.min_gap_mm = std::numeric_limits<double>::infinity();
  for (Eigen::Index v = 0; v < inner.V.rows(); ++v) {
    const Point p(inner.V(v, 0), inner.V(v, 1), inner.V(v, 2));
    if (side(p) != CGAL::ON_BOUNDED_SIDE) ++result.vertices_outside;
    result.min_gap_mm = std::min(result.min_gap_mm, std::sqrt(tree.squared_distance(p)));
  }
  result.all_vertices_inside = result.vertices_outside == 0;
  result.surfaces_intersect =
      PMP::do_intersect(out_mesh, in_mesh, PMP::parameters::do_overlap_test_of_bounded_sides(false),
                        PMP::parameters::do_overlap_test_of_bounded_sides(false));
  return result;
}

}  // namespace lamina::geometry
