#pragma once
// Small hand-made meshes for tests.

#include "lamina/geometry/surface_mesh.h"

namespace lamina::test {

/// A unit-ish octahedron of radius r centred at c, outward winding (closed, genus 0).
inline SurfaceMesh octahedron(double r = 1.0, Eigen::RowVector3d c = Eigen::RowVector3d::Zero()) {
  SurfaceMesh m;
  m.V.resize(6, 3);
  m.V << r, 0, 0, -r, 0, 0, 0, r, 0, 0, -r, 0, 0, 0, r, 0, 0, -r;
  m.V.rowwise() += c;
  m.F.resize(8, 3);
  m.F << 0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5;
  return m;
}

}  // namespace lamina::test
