// Inside or outside the organ, and how deep: the skin's winding number decides the side (robust
// where a nearest-triangle normal is not: at edges and corners), the nearest skin point the depth.
#include "lamina/geometry/winding_number.h"
#include "lamina/interact/contact.h"

namespace lamina::interact {

double depth_under_skin(const Model& model, const Eigen::MatrixX3d& x, const Eigen::Vector3d& p) {
  const double distance = closest_skin_point(model, x, p).distance_mm;
  const bool inside = geometry::winding_number(x, model.layers.at(0).F, p) > 0.5;
  return inside ? distance : -distance;
}

}  // namespace lamina::interact
