#pragma once
/// \file
/// Tetrahedral meshes of an organ mask, the domain of the finite-element reference that the
/// mass-spring model is checked against. Meshing goes through CGAL Mesh_3, which only
/// src/validate/cgal_tet_mesh.cpp sees.

#include <Eigen/Core>

#include "lamina/core/grid.h"

namespace lamina::validate {

/// A volume mesh of linear tetrahedra.
struct TetMesh {
  Eigen::MatrixX3d V;  ///< #V by 3 rest positions, mm (physical space of the mask)
  /// #T by 4 vertex indices; every tet positively oriented:
  /// (V1 - V0) . ((V2 - V0) x (V3 - V0)) > 0.
  Eigen::MatrixX4i T;
};

/// Options for mesh_mask_tets(). Zero means "choose from the mask".
struct TetMeshOptions {
  /// Largest circumradius of a tet, and of a boundary triangle, mm. 0 = the mask's largest
  /// extent / 15 (about 2.7 mm on a 40 mm organ), but never below the largest voxel spacing.
  double cell_size_mm = 0.0;
  /// Largest distance between a boundary triangle and the mask's surface, mm (how closely the
  /// mesh follows curvature). 0 = half the largest voxel spacing: a tighter bound would chase
  /// the voxel staircase, which is as deep as the coarsest axis.
  double facet_distance_mm = 0.0;
  /// Smallest angle of a boundary triangle, degrees (CGAL guarantees termination up to 30).
  double facet_angle_deg = 25.0;
  /// Largest circumradius / shortest edge of a tet; 2 is the smallest CGAL guarantees.
  double cell_radius_edge_ratio = 3.0;
  /// After refinement, CGAL's sliver perturbation and exudation try to lift every dihedral
  /// angle above this, degrees (a sliver makes the stiffness ill-conditioned). 0 = skip both.
  /// They run without CGAL's time limit, so the result stays deterministic. On a 40 mm ball
  /// (7.9k tets): smallest angle 0.9 deg with 0, 10.2 deg with 10, for 0.09 s instead of 0.06 s.
  double sliver_angle_deg = 10.0;
};

/// Meshes the inside of a binary mask with positively oriented tetrahedra (CGAL Mesh_3 on the
/// labelled image, labels trilinearly interpolated so the surface runs about half-way between
/// inside and outside voxel centres and the mesh volume is close to the voxel volume).
/// @param[in] mask     binary mask (1 = inside), any spacing and orientation
/// @param[in] options  sizes; zeros are chosen from the mask
/// @return mesh in physical mm: only vertices used by tets, no degenerate tets, boundary a
///   closed 2-manifold (CGAL's manifold option)
/// \note Deterministic: the same mask and options give the same mesh, bit for bit, run after
///   run (fixed random seeds, sequential meshing, no time-limited optimisation). It reseeds
///   CGAL's thread-local default random generator to do so.
/// \throws lamina::Error (kInvalidInput) for an empty or inconsistent mask, bad options, or a
///   mask too small to give any tet at this cell size.
TetMesh mesh_mask_tets(const Mask& mask, const TetMeshOptions& options);

/// The boundary of a tet mesh: faces used by exactly one tet, wound so their normals point out
/// of that tet (counter-clockwise seen from outside).
/// @param[in] mesh  tet mesh, positively oriented tets
/// @return #F by 3 vertex indices into mesh.V, sorted (deterministic order)
Eigen::MatrixX3i boundary_faces(const TetMesh& mesh);

/// Total signed volume of the tets of `mesh` placed at positions `x`, mm^3.
/// @param[in] mesh  connectivity (mesh.T); mesh.V is not used
/// @param[in] x     #V by 3 positions, mm (mesh.V for the rest volume, V + u when deformed)
/// @return sum over tets of (x1 - x0) . ((x2 - x0) x (x3 - x0)) / 6; inverted tets count negative
/// \throws lamina::Error (kInvalidInput) if a tet indexes past the rows of `x`
double tet_volume(const TetMesh& mesh, const Eigen::MatrixX3d& x);

}  // namespace lamina::validate
