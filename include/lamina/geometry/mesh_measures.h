#pragma once
/// \file
/// Measures and topology checks of triangle meshes (plain Eigen; no CGAL, so cheap to include).

#include <cstdint>
#include <utility>
#include <vector>

#include "lamina/geometry/surface_mesh.h"

namespace lamina::geometry {

/// What a mesh is, for reports and invariant tests.
struct MeshQuality {
  int64_t vertices = 0;
  int64_t faces = 0;
  bool closed = false;           ///< every edge has exactly two faces
  bool manifold = false;         ///< edges in <= 2 faces, consistently oriented, one fan per vertex
  bool outward = false;          ///< enclosed volume > 0 with the faces' winding
  int32_t components = 0;        ///< edge-connected components
  int64_t degenerate_faces = 0;  ///< faces with (near) zero area
  double volume_mm3 = 0.0;       ///< enclosed volume (divergence theorem), mm^3
  double area_mm2 = 0.0;
  double mean_edge_mm = 0.0;
  double min_edge_mm = 0.0;
  double max_edge_mm = 0.0;
  double min_angle_deg = 0.0;  ///< smallest triangle angle
};

/// Measures a mesh. Cost: O(#F log #F).
MeshQuality measure_mesh(const SurfaceMesh& mesh);

/// Enclosed signed volume, mm^3 (positive for a closed outward-wound mesh).
double enclosed_volume(const SurfaceMesh& mesh);

/// The summed area of the triangles F over the vertices V (F's indices into V), mm^2.
double surface_area(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F);

/// Undirected edges of F, each once with first < second, sorted.
std::vector<std::pair<int, int>> mesh_edges(const Eigen::MatrixX3i& F);

/// Component id (0..count-1) of every face; components that share a vertex are one.
/// @param[out] count  number of components
std::vector<int> face_components(const Eigen::MatrixX3i& F, Eigen::Index vertex_count, int& count);

/// Splits a mesh into its components (vertices renumbered per component, order kept).
std::vector<SurfaceMesh> split_components(const SurfaceMesh& mesh);

/// The piece of `mesh` that encloses the largest volume (the mesh itself when it is one piece).
/// @param[out] pieces  optional: how many pieces there were
SurfaceMesh largest_piece(const SurfaceMesh& mesh, int* pieces = nullptr);

/// Concatenates meshes (vertex indices offset).
SurfaceMesh merge_meshes(const std::vector<SurfaceMesh>& meshes);

}  // namespace lamina::geometry
