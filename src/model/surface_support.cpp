#include "lamina/model/surface_support.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>

#include "lamina/core/error.h"

namespace lamina::model {

SurfaceSupport surface_support(const Model& m, const SurfaceSupportOptions& o) {
  if (!(o.direction.norm() > 0.0) || !o.direction.allFinite())
    throw invalid_input("support.direction", "must be a non-zero vector");
  if (!(o.max_angle_deg >= 0.0 && o.max_angle_deg <= 180.0))
    throw invalid_input("support.max_angle_deg",
                        fmt::format("must be between 0 and 180 degrees, got {}", o.max_angle_deg));
  if (!(o.stiffness_kpa_per_mm >= 0.0 && std::isfinite(o.stiffness_kpa_per_mm)))
    throw invalid_input("support.stiffness_kpa_per_mm",
                        fmt::format("must be >= 0 kPa/mm, got {}", o.stiffness_kpa_per_mm));
  SurfaceSupport out;
  if (m.layers.empty()) return out;
  const ModelLayer& skin = m.layers[0];
  // Area-weighted outward normals and vertex areas (a third of each incident triangle).
  Eigen::MatrixX3d normal = Eigen::MatrixX3d::Zero(skin.node_count, 3);
  std::vector<double> area(static_cast<size_t>(skin.node_count), 0.0);
  for (Eigen::Index t = 0; t < skin.F.rows(); ++t) {
    const Eigen::RowVector3d a = m.X.row(skin.F(t, 0)), b = m.X.row(skin.F(t, 1)),
                             c = m.X.row(skin.F(t, 2));
    const Eigen::RowVector3d n = (b - a).cross(c - a);  // twice the area, outward
    for (int k = 0; k < 3; ++k) {
      normal.row(skin.F(t, k) - skin.first_node) += n;
      area[static_cast<size_t>(skin.F(t, k) - skin.first_node)] += n.norm() / 6.0;
    }
  }
  const Eigen::RowVector3d d = o.direction.normalized().transpose();
  const double cos_max = std::cos(o.max_angle_deg * std::numbers::pi / 180.0);
  for (int32_t v = 0; v < skin.node_count; ++v) {
    const double len = normal.row(v).norm();
    if (!(len > 0.0) || normal.row(v).dot(d) / len < cos_max) continue;
    out.nodes.push_back(skin.first_node + v);
    out.stiffness_n_per_m.push_back(o.stiffness_kpa_per_mm * area[static_cast<size_t>(v)]);
    out.area_mm2 += area[static_cast<size_t>(v)];
  }
  return out;
}

}  // namespace lamina::model
