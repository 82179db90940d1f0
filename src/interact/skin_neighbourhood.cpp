#include "lamina/interact/skin_neighbourhood.h"

#include <algorithm>
#include <cmath>

#include "skin_samples.h"

namespace lamina::interact {
namespace {

// The farthest any of the first `nodes` rows of x has moved from `at_scan`, mm. Column by
// column: three contiguous streams the compiler vectorises.
double farthest_move(const Eigen::MatrixX3d& x, const Eigen::MatrixX3d& at_scan, int32_t nodes) {
  const double *x0 = x.col(0).data(), *x1 = x.col(1).data(), *x2 = x.col(2).data();
  const double *s0 = at_scan.col(0).data(), *s1 = at_scan.col(1).data(),
               *s2 = at_scan.col(2).data();
  double most = 0.0;
  for (int32_t i = 0; i < nodes; ++i) {
    const double d0 = x0[i] - s0[i], d1 = x1[i] - s1[i], d2 = x2[i] - s2[i];
    most = std::max(most, d0 * d0 + d1 * d1 + d2 * d2);
  }
  return std::sqrt(most);
}

}  // namespace

const std::vector<int32_t>& skin_faces_near(const Model& m, const Eigen::MatrixX3d& x,
                                            const Eigen::Vector3d& centre, double reach,
                                            SkinNeighbourhood& near) {
  const int32_t skin = m.layers.empty() ? 0 : m.layers[0].node_count;
  if (near.reach_mm >= 0.0 && near.skin_at_scan.rows() == skin) {
    // A triangle left out was farther than reach_mm from the scan's centre; each of its points
    // has since moved at most `moved`, and the centre by `travel`.
    const double travel = (centre - near.centre_mm).norm();
    if (travel + reach <= near.reach_mm &&
        travel + reach + farthest_move(x, near.skin_at_scan, skin) <= near.reach_mm)
      return near.faces;
  }
  near.reach_mm = reach + std::max(0.5 * reach, 2.0);
  near.centre_mm = centre;
  near.skin_at_scan = x.topRows(skin);  // the same size every time: no allocation after the first
  near.faces.clear();
  if (skin > 0) {
    const Eigen::MatrixX3i& F = m.layers[0].F;
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      if (!detail::box_out_of_reach(centre, near.reach_mm, x.row(F(f, 0)).transpose(),
                                    x.row(F(f, 1)).transpose(), x.row(F(f, 2)).transpose()))
        near.faces.push_back(static_cast<int32_t>(f));
  }
  ++near.scans;
  return near.faces;
}

}  // namespace lamina::interact
