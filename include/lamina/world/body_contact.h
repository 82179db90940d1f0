#pragma once
/// \file
/// Contact between bodies' skins: a skin node that has gone inside a skin (another body's, or
/// its own away from itself) and the point of that skin nearest to it. The world finds them
/// after each solve and projects them apart (world.h).

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

namespace lamina::world {

/// A skin node inside a skin.
struct Contact {
  int32_t body = -1;  ///< the node's body (a slot)
  int32_t node = -1;
  int32_t other = -1;                ///< the body whose skin it is in (== body: self-contact)
  std::array<int32_t, 3> corners{};  ///< the triangle of the other's skin nearest to it
  Eigen::Vector3d weights = Eigen::Vector3d::Zero();  ///< the nearest point, barycentric
  Eigen::Vector3d normal = Eigen::Vector3d::UnitX();  ///< the triangle's, outward
  double depth_mm = 0.0;  ///< how far inside, beyond the node's rest overlap
};

}  // namespace lamina::world
