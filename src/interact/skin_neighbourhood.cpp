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

// The same over the listed nodes of x (row k of at_scan is node list[k]'s position then).
double farthest_move(const Eigen::MatrixX3d& x, const Eigen::MatrixX3d& at_scan,
                     const std::vector<int32_t>& list) {
  double most = 0.0;
  for (size_t k = 0; k < list.size(); ++k)
    most =
        std::max(most, (x.row(list[k]) - at_scan.row(static_cast<Eigen::Index>(k))).squaredNorm());
  return std::sqrt(most);
}

// Another surface: its carrying nodes (ascending, each once) and its vertices' largest sum of
// |weights| when the tetrahedra carry it (e), none and 1 for the skin (nullptr); no list yet.
void take_carriers(const EmbeddedSurface* e, SkinNeighbourhood& near) {
  near.carried = e;
  near.carriers.clear();
  near.carried_gain = 1.0;
  near.reach_mm = -1.0;
  if (!e) return;
  near.carriers.assign(e->corners.data(), e->corners.data() + e->corners.size());
  std::sort(near.carriers.begin(), near.carriers.end());
  near.carriers.erase(std::unique(near.carriers.begin(), near.carriers.end()), near.carriers.end());
  if (e->weights.rows() > 0) near.carried_gain = e->weights.cwiseAbs().rowwise().sum().maxCoeff();
}

}  // namespace

const std::vector<int32_t>& skin_faces_near(const Model& m, const Eigen::MatrixX3d& x,
                                            const Eigen::Vector3d& centre, double reach,
                                            SkinNeighbourhood& near) {
  if (m.layers.empty()) {
    near.faces.clear();
    return near.faces;
  }
  return detail::faces_near(detail::skin_view(m, x), centre, reach, near);
}

const std::vector<int32_t>& detail::faces_near(const SurfaceView& s, const Eigen::Vector3d& centre,
                                               double reach, SkinNeighbourhood& near) {
  if (s.carried != near.carried) take_carriers(s.carried, near);  // once per surface
  const Eigen::Index rows =
      s.carried ? static_cast<Eigen::Index>(near.carriers.size()) : s.skin_nodes;
  if (near.reach_mm >= 0.0 && near.skin_at_scan.rows() == rows) {
    // A triangle left out was farther than reach_mm from the scan's centre; each of its points
    // has since moved at most `moved`, and the centre by `travel`.
    const double travel = (centre - near.centre_mm).norm();
    if (travel + reach <= near.reach_mm) {
      const double moved =
          s.carried ? near.carried_gain * farthest_move(s.x, near.skin_at_scan, near.carriers)
                    : farthest_move(s.x, near.skin_at_scan, s.skin_nodes);
      if (travel + reach + moved <= near.reach_mm) return near.faces;
    }
  }
  near.reach_mm = reach + std::max(0.5 * reach, 2.0);
  near.centre_mm = centre;
  // The same size every time: no allocation after the first.
  if (s.carried) {
    near.skin_at_scan.resize(rows, 3);
    for (Eigen::Index k = 0; k < rows; ++k) near.skin_at_scan.row(k) = s.x.row(near.carriers[k]);
  } else {
    near.skin_at_scan = s.x.topRows(rows);
  }
  near.faces.clear();
  const Eigen::MatrixX3i& F = s.F;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    if (!detail::box_out_of_reach(centre, near.reach_mm, s.vertex(F(f, 0)), s.vertex(F(f, 1)),
                                  s.vertex(F(f, 2))))
      near.faces.push_back(static_cast<int32_t>(f));
  if (s.carried) {
    near.vertices.clear();
    for (const int32_t f : near.faces)
      for (int c = 0; c < 3; ++c) near.vertices.push_back(F(f, c));
    std::sort(near.vertices.begin(), near.vertices.end());
    near.vertices.erase(std::unique(near.vertices.begin(), near.vertices.end()),
                        near.vertices.end());
    near.local_corners.clear();
    for (const int32_t f : near.faces)
      for (int c = 0; c < 3; ++c)
        near.local_corners.push_back(static_cast<int32_t>(
            std::lower_bound(near.vertices.begin(), near.vertices.end(), F(f, c)) -
            near.vertices.begin()));
  }
  ++near.scans;
  return near.faces;
}

}  // namespace lamina::interact
