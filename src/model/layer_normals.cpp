#include "lamina/model/layer_normals.h"

#include <Eigen/Geometry>

namespace lamina::model {

Eigen::MatrixX3d layer_normals(const Model& m) {
  Eigen::MatrixX3d n = Eigen::MatrixX3d::Zero(m.node_count(), 3);
  for (const ModelLayer& l : m.layers)
    for (Eigen::Index t = 0; t < l.F.rows(); ++t) {
      const Eigen::RowVector3d a = m.X.row(l.F(t, 0)), b = m.X.row(l.F(t, 1)),
                               c = m.X.row(l.F(t, 2));
      const Eigen::RowVector3d fn = (b - a).cross(c - a);  // twice the area, outward
      for (int k = 0; k < 3; ++k) n.row(l.F(t, k)) += fn;
    }
  for (Eigen::Index i = 0; i < n.rows(); ++i) {
    const double len = n.row(i).norm();
    n.row(i) = len > 0.0 ? Eigen::RowVector3d(n.row(i) / len) : Eigen::RowVector3d(0, 0, 1);
  }
  return n;
}

}  // namespace lamina::model
