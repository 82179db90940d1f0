#pragma once
/// \file
/// Tetrahedra filling the space between nested closed surfaces (TetGen), conforming to them:
/// every surface triangle is a face of the tetrahedral mesh and no point is added on a surface.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace lamina::geometry {

/// Options for tetrahedralize_shells(). The defaults were measured on the phantom and both
/// shared livers (docs/architecture.md): minimum dihedral angle 8-10 degrees, about 0.15
/// interior points per surface point, 20-50 ms for a paper-size two-layer model.
struct TetOptions {
  /// TetGen's radius-edge bound (-q): smaller gives rounder tetrahedra and more interior points.
  double max_radius_edge_ratio = 2.0;
  /// TetGen's dihedral-angle goal (-q .../deg), degrees. With the surfaces kept exactly (-Y),
  /// tetrahedra on a surface cannot always reach it; the result is measured, not assumed.
  double min_dihedral_deg = 10.0;
  /// Runs TetGen's own intersection check (-d) first: TetGen crashes on surfaces that cross.
  /// A caller that has checked the surfaces already (build_model() does, with CGAL) skips it:
  /// it is a second tetrahedralisation, 1.6 of 8.6 s of building a 48k-node liver.
  bool check_intersections = true;
};

/// The tetrahedral mesh of nested surfaces.
struct ShellTets {
  Eigen::MatrixX3d interior_points;  ///< #P by 3 points TetGen added inside (none on a surface), mm
  /// #T by 4 tetrahedra, positively oriented (det[x1 - x0, x2 - x0, x3 - x0] > 0). Indices below
  /// #V are the input vertices; index #V + p is interior point p.
  Eigen::MatrixX4i T;
  /// #T: the region of each tetrahedron, k = the space just inside surface k (between surface k
  /// and the surfaces nested directly inside it; the core when nothing is nested inside k).
  std::vector<int32_t> region;
};

/// Fills the closed, outward-oriented surfaces with tetrahedra (TetGen 1.5: -p a piecewise
/// linear complex, -Y no Steiner point on its facets, -q quality, -A regions).
/// @param[in] V        #V by 3 vertices of every surface, mm
/// @param[in] F        #F by 3 triangles of every surface (outward winding), indices into V
/// @param[in] surface  #F: which surface each triangle belongs to (0 = the outermost, then
///                     inward); surfaces must be nested and must not touch
/// @param[in] options  quality bounds
/// @return tetrahedra and interior points; every triangle of F is a face of exactly one
///   tetrahedron of the region just inside its surface (and, for an inner surface, of one
///   outside it), and the tetrahedra's volumes sum to the volume inside surface 0
/// \note Throws lamina::Error (kInternal) when TetGen fails or its output breaks these
///   promises (surfaces that cross or touch), with the message saying so.
ShellTets tetrahedralize_shells(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                const std::vector<int32_t>& surface,
                                const TetOptions& options = {});

}  // namespace lamina::geometry
