#pragma once
/// \file
/// How a plane divides a tetrahedral volume (resection planning: the volume left on each side).

#include <Eigen/Core>
#include <cstdint>

#include "lamina/core/grid.h"

namespace lamina::geometry {

/// The volume of a tetrahedron on each side of a plane, mm^3.
struct PlaneSides {
  double front_mm3 = 0.0;  ///< where (x - point) . normal > 0
  double back_mm3 = 0.0;   ///< the rest
};

/// The tetrahedra T (#T by 4, rows of X) on each side of the plane through `point` with
/// `normal` (any length but zero), each tetrahedron clipped by the plane exactly: the part in
/// front is a tetrahedron, a wedge or the whole, by how many corners are in front. Volumes are
/// unsigned. Throws lamina::Error (kInvalidInput) for a normal of zero length or a point or
/// normal that is not finite.
PlaneSides volume_by_plane(const Eigen::MatrixX3d& X, const Eigen::MatrixX4i& T,
                           const Eigen::Vector3d& point, const Eigen::Vector3d& normal);

/// The volume a closed, outward-wound triangle surface encloses on each side of the same plane,
/// exactly (each triangle clipped; the cap the plane makes adds nothing to cones from a point on
/// it). Throws as volume_by_plane for a bad plane.
PlaneSides surface_volume_by_plane(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                   const Eigen::Vector3d& point, const Eigen::Vector3d& normal);

/// The voxels of `labels` holding `label` (every label > 0 when `label` is 0) on each side of the
/// same plane, each voxel on the side of its centre (in physical space: the grid's spacing,
/// origin and direction), mm^3: the reference a model's volumes are checked against. Throws as
/// volume_by_plane for a bad plane.
PlaneSides voxel_volume_by_plane(const LabelVolume& labels, int32_t label,
                                 const Eigen::Vector3d& point, const Eigen::Vector3d& normal);

}  // namespace lamina::geometry
