// The surface a tool touches, and how deep a point lies under it. The display skin is the organ's
// own boundary at the segmentation's resolution, up to a few mm outside the simulation's skin
// where the organ is convex: touched there, a tool rests on what the viewer draws.
#include "lamina/geometry/winding_number.h"
#include "lamina/model/embed_surface.h"
#include "skin_samples.h"

namespace lamina::interact {

detail::SurfaceView detail::touch_view(const Model& m, const Eigen::MatrixX3d& x, Touch touch) {
  SurfaceView s = skin_view(m, x);
  const int32_t k = touch == Touch::kDisplaySkin ? model::display_skin_index(m) : -1;
  if (k < 0) return s;
  const EmbeddedSurface& e = m.embedded[static_cast<size_t>(k)];
  return {.F = e.F, .x = x, .carried = &e, .skin_nodes = s.skin_nodes};
}

double detail::depth_under(const SurfaceView& s, const Eigen::Vector3d& p,
                           Eigen::MatrixX3d& scratch) {
  if (s.carried) {
    // Every vertex is read: their positions W x once (threaded; `scratch` sized once), then the
    // plain surface's depth.
    model::embedded_positions(*s.carried, s.x, scratch);
    return depth_under(SurfaceView{.F = s.F, .x = scratch}, p, scratch);
  }
  const double distance = closest_on_faces(s, p).distance_mm;
  return geometry::winding_number(s.x, s.F, p) > 0.5 ? distance : -distance;
}

}  // namespace lamina::interact
