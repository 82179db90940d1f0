// The skin area each node stands for: a tie's stiffness and strength, a contact spring's
// stiffness, are per unit area.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "world_work.h"

namespace lamina::world::detail {

std::vector<double> skin_node_area(const Model& model) {
  std::vector<double> area(static_cast<size_t>(model.node_count()), 0.0);
  const Eigen::MatrixX3i& F = model.layers.front().F;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = model.X.row(F(f, 0)), b = model.X.row(F(f, 1)),
                          c = model.X.row(F(f, 2));
    const double third = (b - a).cross(c - a).norm() / 6.0;
    for (int k = 0; k < 3; ++k) area[static_cast<size_t>(F(f, k))] += third;
  }
  return area;
}

}  // namespace lamina::world::detail
