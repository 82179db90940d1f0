#pragma once
/// \file
/// The skin triangles near a moving point, kept from step to step: a Verlet list (as molecular
/// dynamics keeps its neighbour lists). A scan of the whole skin lists the triangles within a
/// margin beyond the reach asked for; later queries reuse the list while the point and the skin
/// have together moved less than that margin since the scan, which one pass over the skin's node
/// positions (contiguous, no triangle gathers) tells. A haptic tip asks every step at 1 kHz;
/// the scan is what grows with the skin, and it now runs only when the tip has travelled its
/// margin (docs/benchmarks.md, sim_bench BM_ToolTipContact).

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "lamina/model/model.h"

namespace lamina::interact {

struct SkinNeighbourhood {
  std::vector<int32_t> faces;  ///< rows of the surface's F within reach_mm of centre_mm at the scan
  Eigen::Vector3d centre_mm = Eigen::Vector3d::Zero();
  double reach_mm = -1.0;         ///< the listed reach, margin included; < 0: no scan yet
  Eigen::MatrixX3d skin_at_scan;  ///< the carrying nodes' positions at the scan
  int64_t scans = 0;              ///< whole-surface scans so far
  /// For a surface the tetrahedra carry (a display skin): which one, the nodes that carry it
  /// (ascending), and the most any of its vertices moves per mm its carrying nodes move (the
  /// largest sum of |weights| of a vertex; 1 inside its tetrahedron).
  const EmbeddedSurface* carried = nullptr;
  std::vector<int32_t> carriers;
  double carried_gain = 1.0;
  /// For a carried surface: the listed triangles' vertices (ascending, each once) and, per
  /// listed triangle, its corners as indices into them, so that a step computes each vertex's
  /// W x once rather than once per triangle.
  std::vector<int32_t> vertices;
  std::vector<int32_t> local_corners;
};

/// Every skin triangle that comes within `reach_mm` of `centre_mm` at positions x, and maybe a
/// few more (a superset, in ascending order): from `near`'s list when it still covers the
/// query, else from a new scan of the skin with a margin of max(reach_mm / 2, 2 mm). The list is
/// `near.faces`; it stays valid until the next call.
const std::vector<int32_t>& skin_faces_near(const Model& model, const Eigen::MatrixX3d& x,
                                            const Eigen::Vector3d& centre_mm, double reach_mm,
                                            SkinNeighbourhood& near);

}  // namespace lamina::interact
