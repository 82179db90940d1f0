#pragma once
/// \file
/// Near-uniform remeshing and mesh repair, through CGAL's Polygon Mesh Processing.

#include <cstdint>
#include <vector>

#include "lamina/geometry/surface_mesh.h"

namespace lamina::geometry {

/// Options for remesh().
struct RemeshOptions {
  double target_edge_mm = 5.0;  ///< desired edge length, mm, > 0
  int iterations = 5;           ///< split/collapse/flip/relax rounds
};

/// Isotropic remeshing (Botsch-Kobbelt, CGAL PMP::isotropic_remeshing): near-equilateral
/// triangles of about `target_edge_mm`, vertices projected back onto the input surface.
/// @param[in] input    closed triangle mesh (a polygon soup is repaired and oriented first)
/// @param[in] options  target edge length and rounds
/// @return closed, consistently oriented mesh, same orientation as the input
SurfaceMesh remesh(const SurfaceMesh& input, const RemeshOptions& options);

/// True when two triangles of the mesh intersect other than at a shared edge or vertex.
bool self_intersects(const SurfaceMesh& mesh);

/// Where the mesh crosses itself: the mean of the centroids of its intersecting triangles
/// (mm), and how many pairs there are; {} when it does not. For error messages.
struct SelfIntersection {
  int64_t pairs = 0;
  Eigen::Vector3d where = Eigen::Vector3d::Zero();
};
SelfIntersection find_self_intersection(const SurfaceMesh& mesh);

/// How `inner` sits relative to `outer`.
struct Nesting {
  bool all_vertices_inside = false;  ///< every vertex of inner is strictly inside outer
  int64_t vertices_outside = 0;      ///< vertices of inner on or outside outer
  bool surfaces_intersect = true;    ///< some triangle of inner crosses a triangle of outer
  double min_gap_mm = 0.0;           ///< smallest distance from an inner vertex to outer
  bool nested() const { return all_vertices_inside && !surfaces_intersect; }
};

/// Distances from the vertices of one surface to another.
struct SurfaceDistance {
  double mean_mm = 0.0;  ///< mean vertex-to-surface distance
  double rms_mm = 0.0;
  double max_mm = 0.0;  ///< one-sided Hausdorff distance (at the vertices)
};

/// Distance from every vertex of `from` to the nearest point on the triangles of `to`
/// (AABB tree). Not symmetric: swap the arguments for the other direction.
SurfaceDistance surface_distance(const SurfaceMesh& from, const SurfaceMesh& to);

/// Checks that `inner` lies strictly inside the closed surface `outer` (AABB tree queries).
Nesting check_nesting(const SurfaceMesh& outer, const SurfaceMesh& inner);

}  // namespace lamina::geometry
