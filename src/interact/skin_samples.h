#pragma once
// Internal to interact's contact files: the closest point of a triangle, sample points over the
// skin near a centre, and the merge of per-node force parts into a ForceRoute.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "lamina/geometry/closest_on_triangle.h"
#include "lamina/interact/contact.h"
#include "lamina/interact/tools.h"
#include "lamina/model/model.h"

namespace lamina::interact::detail {

// True when no point of the triangle can be within `reach` of `centre` (its bounding box is
// farther): the cheap test before closest_on_triangle.
inline bool box_out_of_reach(const Eigen::Vector3d& centre, double reach, const Eigen::Vector3d& a,
                             const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d lo = a.cwiseMin(b).cwiseMin(c), hi = a.cwiseMax(b).cwiseMax(c);
  const Eigen::Vector3d gap = (lo - centre).cwiseMax(centre - hi).cwiseMax(0.0);
  return gap.squaredNorm() > reach * reach;
}

// Calls visit(f) for each row f of F, or for each entry of `list` when one is given (the
// triangles a SkinNeighbourhood found near a point).
template <class Visit>
void for_faces(const Eigen::MatrixX3i& F, const std::vector<int32_t>* list, Visit&& visit) {
  if (list)
    for (const int32_t f : *list) visit(static_cast<Eigen::Index>(f));
  else
    for (Eigen::Index f = 0; f < F.rows(); ++f) visit(f);
}

// The point of the triangles F (rows index x; only the listed ones when `list` is given) nearest
// to p: brute force with a box reject per triangle (the skin moves every step, so a search tree
// would be rebuilt per query; a haptic tip asking every step keeps a SkinNeighbourhood).
inline SkinPoint closest_on_faces(const Eigen::MatrixX3i& F, const Eigen::MatrixX3d& x,
                                  const Eigen::Vector3d& p,
                                  const std::vector<int32_t>* list = nullptr) {
  SkinPoint best;
  for_faces(F, list, [&](Eigen::Index f) {
    const Eigen::Vector3d a = x.row(F(f, 0)), b = x.row(F(f, 1)), c = x.row(F(f, 2));
    if (best.face >= 0 && box_out_of_reach(p, best.distance_mm, a, b, c)) return;
    const Eigen::Vector3d w = geometry::closest_on_triangle(p, a, b, c);
    const Eigen::Vector3d q = w[0] * a + w[1] * b + w[2] * c;
    const double d = (q - p).norm();
    if (d < best.distance_mm)
      best = {.face = static_cast<int32_t>(f), .barycentric = w, .point_mm = q, .distance_mm = d};
  });
  return best;
}

// Calls visit(face, barycentric, point, area) at sample points of every triangle of F (rows
// index x: the skin, or a finite-element mesh's boundary) that comes within `reach` of `centre`.
// Each such triangle is cut into k x k similar pieces (k^2 samples at the pieces' centroids,
// each standing for area / k^2), k = cuts(face, barycentric weights of its point nearest to the
// centre, that point's distance, the triangle's longest edge), clamped to 1..16. With `list`,
// only the listed triangles are looked at (a superset of those within reach).
template <class Cuts, class Visit>
void sample_faces_near(const Eigen::MatrixX3i& F, const Eigen::MatrixX3d& x,
                       const Eigen::Vector3d& centre, double reach, Cuts&& cuts, Visit&& visit,
                       const std::vector<int32_t>* list = nullptr) {
  for_faces(F, list, [&](Eigen::Index f) {
    const Eigen::Vector3d a = x.row(F(f, 0)), b = x.row(F(f, 1)), c = x.row(F(f, 2));
    if (box_out_of_reach(centre, reach, a, b, c)) return;
    const Eigen::Vector3d w = geometry::closest_on_triangle(centre, a, b, c);
    const double distance = (w[0] * a + w[1] * b + w[2] * c - centre).norm();
    if (distance > reach) return;
    const double longest =
        std::sqrt(std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()}));
    const int k = std::clamp(cuts(static_cast<int32_t>(f), w, distance, longest), 1, 16);
    const double area = 0.5 * (b - a).cross(c - a).norm() / (k * k);
    const double inv = 1.0 / k;
    for (int i = 0; i < k; ++i)
      for (int j = 0; i + j < k; ++j) {
        // The piece with corners (i, j), (i + 1, j), (i, j + 1) in steps of 1/k along b and c,
        // and, unless at the far edge, the flipped piece beside it.
        for (int flip = 0; flip < (i + j + 1 < k ? 2 : 1); ++flip) {
          const double third = flip ? 2.0 / 3.0 : 1.0 / 3.0;
          const double wb = (i + third) * inv, wc = (j + third) * inv;
          const Eigen::Vector3d bary(1.0 - wb - wc, wb, wc);
          visit(static_cast<int32_t>(f), bary, Eigen::Vector3d(a + wb * (b - a) + wc * (c - a)),
                area);
        }
      }
  });
}

// The same over the model's skin.
template <class Cuts, class Visit>
void sample_skin_near(const Model& m, const Eigen::MatrixX3d& x, const Eigen::Vector3d& centre,
                      double reach, Cuts&& cuts, Visit&& visit,
                      const std::vector<int32_t>* list = nullptr) {
  sample_faces_near(m.layers[0].F, x, centre, reach, std::forward<Cuts>(cuts),
                    std::forward<Visit>(visit), list);
}

// spread_on_patch over the listed skin triangles only (a superset of those within radius_mm of
// the contact point; nullptr: all), for a caller that keeps a SkinNeighbourhood.
ForceRoute spread_on_listed(const Model& model, const Eigen::MatrixX3d& x, const SkinPoint& at,
                            const Eigen::Vector3d& force_mn, double radius_mm,
                            const std::vector<int32_t>* list);

// Cuts so that a piece is no wider than `spacing` (mm) on an edge of length `longest`.
inline int cuts_for(double longest, double spacing) {
  return spacing > 0.0 ? static_cast<int>(std::min(std::ceil(longest / spacing), 16.0)) : 16;
}

// Per-node force parts merged into a route (nodes ascending, each once). `parts` is reused
// scratch: sorted in place.
inline void merge_parts(std::vector<std::pair<int32_t, Eigen::Vector3d>>& parts, ForceRoute& out) {
  std::sort(parts.begin(), parts.end(),
            [](const auto& l, const auto& r) { return l.first < r.first; });
  out.nodes.clear();
  for (const auto& part : parts)
    if (out.nodes.empty() || out.nodes.back() != part.first) out.nodes.push_back(part.first);
  out.forces.setZero(static_cast<Eigen::Index>(out.nodes.size()), 3);
  Eigen::Index row = -1;
  int32_t last = -1;
  for (const auto& [node, f] : parts) {
    if (node != last) ++row, last = node;
    out.forces.row(row) += f.transpose();
  }
}

}  // namespace lamina::interact::detail
