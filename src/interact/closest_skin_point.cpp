#include <fmt/format.h>

#include "lamina/core/error.h"
#include "lamina/interact/contact.h"
#include "skin_samples.h"

namespace lamina::interact {

SkinPoint closest_skin_point(const Model& m, const Eigen::MatrixX3d& x, const Eigen::Vector3d& p) {
  if (m.layers.empty()) return {};
  return detail::closest_on_faces(detail::skin_view(m, x), p);
}

SkinPoint skin_point_at_node(const Model& m, const Eigen::MatrixX3d& x, int32_t node) {
  const int32_t skin = m.layers.empty() ? 0 : m.layers[0].node_count;
  if (node < 0 || node >= skin)
    throw invalid_input("skin node", fmt::format("must be 0..{}, got {}", skin - 1, node));
  const Eigen::MatrixX3i& F = m.layers[0].F;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c)
      if (F(f, c) == node) {
        SkinPoint at{.face = static_cast<int32_t>(f), .point_mm = x.row(node).transpose()};
        at.barycentric[c] = 1.0;
        at.distance_mm = 0.0;
        return at;
      }
  throw invalid_input("skin node", fmt::format("{} belongs to no skin triangle", node));
}

}  // namespace lamina::interact
