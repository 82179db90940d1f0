#pragma once
/// \file
/// The generalised winding number of a closed triangle mesh at a point (Jacobson et al. 2013):
/// the solid angles its triangles subtend, over 4 pi. 1 inside a closed outward mesh, 0 outside,
/// 1/2 on it; robust to small holes and self-intersections. O(#F) per query: for one-off
/// questions (is this tool inside the organ?), not for a field.

#include <Eigen/Core>

namespace lamina::geometry {

/// @param[in] V  vertex positions (rows), mm
/// @param[in] F  triangles, rows of V, outward winding
/// @param[in] p  the query point
double winding_number(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                      const Eigen::Vector3d& p);

}  // namespace lamina::geometry
