// Picking a world's bodies (pick_body.h): each body's skin by interact::pick_skin, the nearest.
#include "lamina/world/pick_body.h"

namespace lamina::world {

BodyHit pick_body(const WorldSnapshot& snapshot, const Eigen::Vector3d& origin,
                  const Eigen::Vector3d& direction) {
  BodyHit best;
  for (size_t b = 0; b < snapshot.bodies.size(); ++b) {
    const BodyView& body = snapshot.bodies[b];
    const interact::SkinHit hit = interact::pick_skin(*body.model, body.x, origin, direction);
    if (hit.node >= 0 && (best.body < 0 || hit.distance_mm < best.skin.distance_mm))
      best = {static_cast<int32_t>(b), hit};
  }
  return best;
}

}  // namespace lamina::world
