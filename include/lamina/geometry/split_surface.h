#pragma once
/// \file
/// Cutting a fine surface along another: the display skin and the embedded structures along a
/// blade's swept surface (CGAL's Polygon Mesh Processing), and the loops a cut leaves closed.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "lamina/geometry/surface_mesh.h"

namespace lamina::geometry {

/// A surface split along another.
struct SplitSurface {
  Eigen::MatrixX3d V;  ///< the vertices: the input's (those kept) and the ones made on the cut
  Eigen::MatrixX3i F;  ///< the triangles, the input's winding
  /// Per vertex of V: the input vertex it is, or -1 for one made where the surfaces cross (each
  /// side of the cut has its own: the cut opens there)
  std::vector<int32_t> origin;
};

/// The triangle mesh `mesh` split along the surface `splitter` (CGAL PMP::split: the two are
/// corefined and the edges on their intersection duplicated, one copy per side). Triangles the
/// splitter does not cross are kept as they were.
/// @param[in] mesh      an edge-manifold patch (it may have a boundary); a vertex where two fans
///                      meet is taken apart first and comes back as the same origin
/// @param[in] splitter  a triangle surface that does not cross itself (it is not modified)
/// \note Throws lamina::Error (kInvalidInput) "split: ..." when CGAL cannot split them.
SplitSurface split_surface(const SurfaceMesh& mesh, const SurfaceMesh& splitter);

/// Triangles closing a loop of points (a hole's boundary, in order), from CGAL's
/// PMP::triangulate_hole_polyline, as rows of indices into `loop`, wound so that each loop edge
/// (loop[k], loop[k+1]) runs from loop[k+1] to loop[k] in its triangle: the cap continues a
/// surface whose boundary edges run in the loop's order. Empty when CGAL finds no triangulation.
/// @param[in] loop  >= 3 points, not repeated
Eigen::MatrixX3i fill_loop(const Eigen::MatrixX3d& loop);

}  // namespace lamina::geometry
