// Inside or outside the organ, and how deep: the skin's winding number decides the side (robust
// where a nearest-triangle normal is not: at edges and corners), the nearest skin point the depth.
#include "lamina/interact/contact.h"
#include "skin_samples.h"

namespace lamina::interact {

double depth_under_skin(const Model& model, const Eigen::MatrixX3d& x, const Eigen::Vector3d& p) {
  Eigen::MatrixX3d unused;
  return detail::depth_under(detail::skin_view(model, x), p, unused);
}

}  // namespace lamina::interact
