#include "lamina/geometry/measure_tets.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace lamina::geometry {

TetQuality measure_tets(const Eigen::MatrixX3d& X, const Eigen::MatrixX4i& T) {
  TetQuality q;
  q.count = T.rows();
  if (q.count == 0) return q;
  q.min_dihedral_deg = 180.0;
  q.min_volume_mm3 = std::numeric_limits<double>::infinity();
  // Faces opposite each corner, wound so that their normals point out of a positive tet.
  constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  double sum = 0.0;
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    Eigen::Vector3d p[4];
    for (int c = 0; c < 4; ++c) p[c] = X.row(T(t, c)).transpose();
    const double volume = (p[1] - p[0]).cross(p[2] - p[0]).dot(p[3] - p[0]) / 6.0;
    q.volume_mm3 += volume;
    q.min_volume_mm3 = std::min(q.min_volume_mm3, volume);
    if (!(volume > 0.0)) ++q.inverted;
    Eigen::Vector3d n[4];
    for (int f = 0; f < 4; ++f)
      n[f] = (p[kFace[f][1]] - p[kFace[f][0]]).cross(p[kFace[f][2]] - p[kFace[f][0]]).normalized();
    // The dihedral angle along the edge two faces share is pi minus the angle of their outward
    // normals.
    double smallest = 180.0;
    for (int f = 0; f < 4; ++f)
      for (int g = f + 1; g < 4; ++g) {
        const double angle =
            180.0 - std::acos(std::clamp(n[f].dot(n[g]), -1.0, 1.0)) * 180.0 / std::numbers::pi;
        smallest = std::min(smallest, angle);
        q.max_dihedral_deg = std::max(q.max_dihedral_deg, angle);
        sum += angle;
      }
    q.min_dihedral_deg = std::min(q.min_dihedral_deg, smallest);
    if (smallest < TetQuality::kSliverDeg) ++q.slivers;
    if (smallest < 10.0) ++q.below_10_deg;
  }
  q.mean_dihedral_deg = sum / (6.0 * static_cast<double>(q.count));
  return q;
}

}  // namespace lamina::geometry
