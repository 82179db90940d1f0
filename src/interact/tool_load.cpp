// The one pipeline from a pushing tool to forces on nodes: contact (contact.h), then routing.

#include <cmath>

#include "lamina/interact/contact.h"
#include "lamina/interact/haptic_proxy.h"
#include "lamina/interact/tools.h"
#include "skin_samples.h"

namespace lamina::interact {
namespace {

// The paper's tool tip touches the deepest skin node inside the sphere, or none (-1). Brute
// force: a k-d tree rebuilt at 1 kHz on a moving skin would cost more than this scan.
int32_t deepest_node_inside(const Model& m, const Eigen::MatrixX3d& x, const ToolTip& tip,
                            double& distance) {
  int32_t best = -1;
  double best_d2 = tip.radius_mm * tip.radius_mm;
  const int32_t skin = m.layers.empty() ? 0 : m.layers[0].node_count;
  for (int32_t i = 0; i < skin; ++i) {
    const double d2 = (x.row(i).transpose() - tip.center_mm).squaredNorm();
    if (d2 < best_d2) best_d2 = d2, best = i;
  }
  distance = std::sqrt(best_d2);
  return best;
}

}  // namespace

ForceRoute load_at_node(const Model& m, const Eigen::MatrixX3d& x, int32_t node,
                        const Eigen::Vector3d& force_mn, double radius_mm,
                        const RoutingOptions& o) {
  if (o.routing == Routing::kPaper) return route_force(m, x, node, force_mn, o);
  const SkinPoint at = skin_point_at_node(m, x, node);
  const detail::SurfaceView touched = detail::touch_view(m, x, o.touch);
  if (!touched.carried) return spread_on_patch(m, x, at, force_mn, radius_mm);
  // On the display skin: at its point nearest to the node (the node lies on the simulation's
  // skin, at most a few mm inside the display skin).
  return detail::spread_on_surface(touched, detail::closest_on_faces(touched, at.point_mm),
                                   force_mn, radius_mm);
}

ForceRoute load_at_point(const Model& m, const Eigen::MatrixX3d& x, const Eigen::Vector3d& point_mm,
                         const Eigen::Vector3d& force_mn, double radius_mm,
                         const RoutingOptions& o) {
  if (o.routing == Routing::kPaper) {
    const int32_t node = nearest_skin_node(m, x, point_mm, o.contact_threshold_mm);
    return node < 0 ? ForceRoute{} : route_force(m, x, node, force_mn, o);
  }
  const detail::SurfaceView touched = detail::touch_view(m, x, o.touch);
  const SkinPoint at = detail::closest_on_faces(touched, point_mm);
  if (!(at.distance_mm <= o.contact_threshold_mm)) return {};
  return detail::spread_on_surface(touched, at, force_mn, radius_mm);
}

ForceRoute load_of_tip(const Model& m, const Eigen::MatrixX3d& x, const ToolTip& tip,
                       const RoutingOptions& o, HapticProxy& proxy) {
  if (o.routing == Routing::kNone) return couple_proxy(m, x, tip, proxy, o.touch);
  proxy = {};
  if (!tip.active) return {};
  double distance = 0.0;
  const int32_t node = deepest_node_inside(m, x, tip, distance);
  if (node < 0) return {};
  Eigen::Vector3d dir = x.row(node).transpose() - tip.center_mm;
  dir = dir.norm() > 1e-9 ? dir.normalized() : Eigen::Vector3d(0, 1, 0);
  const Eigen::Vector3d push = tip.stiffness_n_per_m * (tip.radius_mm - distance) * dir;
  proxy.device_force_mn = -push;
  proxy.touching = true;
  return route_force(m, x, node, push, o);
}

Eigen::Vector3d total_force(const ForceRoute& route) {
  return route.forces.rows() > 0 ? Eigen::Vector3d(route.forces.colwise().sum().transpose())
                                 : Eigen::Vector3d::Zero();
}

}  // namespace lamina::interact
