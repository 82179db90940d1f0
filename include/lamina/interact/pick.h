#pragma once
/// \file
/// Picking the skin with a ray (a mouse click, a tool shaft): the first skin triangle the ray
/// hits at the current positions, and the node nearest to the hit.

#include <Eigen/Core>
#include <cstdint>

#include "lamina/model/model.h"

namespace lamina::interact {

struct SkinHit {
  int32_t node = -1;  ///< the hit triangle's vertex nearest to the hit point; -1 = missed
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  ///< the hit point, mm
  double distance_mm = 0.0;                         ///< along the ray from its origin
};

/// The first hit of the ray origin + t * direction (t > 0) on the skin (layer 0) at positions x
/// (#nodes by 3, mm). Brute force over the skin's triangles (the skin moves every step, so a
/// search tree would be rebuilt per pick): 22 us for 2.5k triangles, 0.5 ms for 25k (median,
/// bench/sim_bench BM_PickSkin); called once per mouse press.
SkinHit pick_skin(const Model& model, const Eigen::MatrixX3d& x, const Eigen::Vector3d& origin,
                  const Eigen::Vector3d& direction);

}  // namespace lamina::interact
