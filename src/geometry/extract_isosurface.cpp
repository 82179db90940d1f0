// The only translation unit that sees OpenVDB.
#include "lamina/geometry/extract_isosurface.h"

#include <openvdb/openvdb.h>
#include <openvdb/tools/Dense.h>
#include <openvdb/tools/VolumeToMesh.h>

#include <Eigen/Geometry>
#include <mutex>

namespace lamina::geometry {

SurfaceMesh extract_isosurface(const DistanceField& field, double iso_mm, double adaptivity) {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });

  const GridFrame& f = field.frame;
  // LayoutXYZ is OpenVDB's x-fastest layout, the same as our buffers (offset i + j*nx + ...).
  const openvdb::CoordBBox box(
      openvdb::Coord(0, 0, 0),
      openvdb::Coord(static_cast<int>(f.size[0] - 1), static_cast<int>(f.size[1] - 1),
                     static_cast<int>(f.size[2] - 1)));
  openvdb::tools::Dense<const float, openvdb::tools::LayoutXYZ> dense(box, field.phi.data());
  // Background = "far outside"; with zero tolerance every voxel stays active, so the grid is
  // an exact copy of the dense field.
  auto grid = openvdb::FloatGrid::create(std::numeric_limits<float>::max());
  openvdb::tools::copyFromDense(dense, *grid, 0.0f);

  std::vector<openvdb::Vec3s> points;
  std::vector<openvdb::Vec3I> tris;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(*grid, points, tris, quads, iso_mm, adaptivity);

  SurfaceMesh mesh;
  mesh.V.resize(static_cast<Eigen::Index>(points.size()), 3);
  for (size_t n = 0; n < points.size(); ++n) {
    const auto p = f.to_physical(points[n][0], points[n][1], points[n][2]);
    mesh.V.row(static_cast<Eigen::Index>(n)) << p[0], p[1], p[2];
  }
  mesh.F.resize(static_cast<Eigen::Index>(tris.size() + 2 * quads.size()), 3);
  Eigen::Index t = 0;
  for (const auto& tri : tris) mesh.F.row(t++) << tri[0], tri[1], tri[2];
  for (const auto& q : quads) {
    // Split along the shorter diagonal: better triangles for the remesher to start from.
    const double d02 = (mesh.V.row(q[0]) - mesh.V.row(q[2])).squaredNorm();
    const double d13 = (mesh.V.row(q[1]) - mesh.V.row(q[3])).squaredNorm();
    if (d02 <= d13) {
      mesh.F.row(t++) << q[0], q[1], q[2];
      mesh.F.row(t++) << q[0], q[2], q[3];
    } else {
      mesh.F.row(t++) << q[0], q[1], q[3];
      mesh.F.row(t++) << q[1], q[2], q[3];
    }
  }
  // Orientation: OpenVDB's winding convention combined with a possibly mirrored direction
  // matrix (det < 0) decides the sign; make the enclosed signed volume positive.
  double volume6 = 0.0;
  for (Eigen::Index r = 0; r < mesh.F.rows(); ++r)
    volume6 +=
        mesh.V.row(mesh.F(r, 0)).dot(mesh.V.row(mesh.F(r, 1)).cross(mesh.V.row(mesh.F(r, 2))));
  if (volume6 < 0.0) mesh.F.col(1).swap(mesh.F.col(2));
  return mesh;
}

}  // namespace lamina::geometry
