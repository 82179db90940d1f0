#include <vector>

#include "lamina/interact/contact.h"
#include "skin_samples.h"

namespace lamina::interact {

ForceRoute sphere_contact(const Model& m, const Eigen::MatrixX3d& x, const PressingSphere& sphere) {
  ForceRoute route;
  if (m.layers.empty()) return route;
  const Eigen::MatrixX3i& F = m.layers[0].F;
  thread_local std::vector<PressedPiece> pieces;
  thread_local std::vector<std::pair<int32_t, Eigen::Vector3d>> parts;
  press_sphere(x, m.X, F, sphere, pieces);
  if (pieces.empty()) return route;  // not touching
  parts.clear();
  double deepest = 0.0;
  for (const PressedPiece& p : pieces) {
    for (int k = 0; k < 3; ++k)
      if (p.barycentric[k] != 0.0) parts.emplace_back(F(p.face, k), p.barycentric[k] * p.force_mn);
    // The node the piece pressed hardest leans on most: the contact node of the route.
    const double load = p.force_mn.norm() / p.stiffness_mn_per_mm;
    if (load > deepest) {
      deepest = load;
      int best = 0;
      p.barycentric.maxCoeff(&best);
      route.contact_node = F(p.face, best);
    }
  }
  detail::merge_parts(parts, route);
  return route;
}

}  // namespace lamina::interact
