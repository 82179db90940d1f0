#pragma once
/// \file
/// Picking a world's bodies with a ray (a mouse press in the viewer or on the web page): the
/// first skin any body's ray meets, at the positions of a snapshot.

#include <Eigen/Core>
#include <cstdint>

#include "lamina/interact/pick.h"
#include "lamina/world/world_loop.h"

namespace lamina::world {

struct BodyHit {
  int32_t body = -1;       ///< index into snapshot.bodies; -1: the ray met no skin
  interact::SkinHit skin;  ///< on that body's skin (its node, point and distance)
};

/// The nearest hit of origin + t * direction (t > 0) on any body's skin (interact::pick_skin).
BodyHit pick_body(const WorldSnapshot& snapshot, const Eigen::Vector3d& origin,
                  const Eigen::Vector3d& direction);

}  // namespace lamina::world
