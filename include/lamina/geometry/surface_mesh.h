#pragma once
/// \file
/// A triangle mesh in libigl's layout: V (#V by 3, mm) and F (#F by 3, vertex indices,
/// counter-clockwise seen from outside, so normals point outward).

#include <Eigen/Core>

namespace lamina {

struct SurfaceMesh {
  Eigen::MatrixX3d V;  ///< #V by 3 vertex positions, mm
  Eigen::MatrixX3i F;  ///< #F by 3 triangles, outward (counter-clockwise) winding
};

}  // namespace lamina
