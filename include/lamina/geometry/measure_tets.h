#pragma once
/// \file
/// Shape measures of a tetrahedral mesh: dihedral angles, inverted and flat (sliver) elements.

#include <Eigen/Core>
#include <cstdint>

namespace lamina::geometry {

/// Quality of a tetrahedral mesh.
struct TetQuality {
  int64_t count = 0;
  double min_dihedral_deg = 0.0;   ///< smallest dihedral angle of any tetrahedron
  double mean_dihedral_deg = 0.0;  ///< over all six angles of every tetrahedron
  double max_dihedral_deg = 0.0;
  int64_t inverted = 0;      ///< tetrahedra with volume <= 0
  int64_t slivers = 0;       ///< tetrahedra with a dihedral angle under kSliverDeg
  int64_t below_10_deg = 0;  ///< tetrahedra with a dihedral angle under 10 degrees
  double min_volume_mm3 = 0.0;
  double volume_mm3 = 0.0;  ///< total signed volume
  /// A tetrahedron with a dihedral angle under this many degrees is a sliver (flat: it resists
  /// little and inverts easily).
  static constexpr double kSliverDeg = 5.0;
};

/// Measures the tetrahedra T (#T by 4) on positions X (#V by 3).
TetQuality measure_tets(const Eigen::MatrixX3d& X, const Eigen::MatrixX4i& T);

}  // namespace lamina::geometry
