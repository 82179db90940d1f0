#pragma once
/// \file
/// Contact on the skin's surface: where a tool meets the current skin triangles, and which nodes
/// carry its load, by the barycentric weights of the contact points. The forces each function
/// returns sum to the load on the tissue; the tool receives exactly minus that sum (Newton's
/// third law). No routing here: tools.h's pipeline adds the paper's copies when asked to.

#include <Eigen/Core>
#include <cstdint>
#include <limits>

#include "lamina/interact/sphere_pressure.h"
#include "lamina/interact/tools.h"
#include "lamina/model/model.h"

namespace lamina::interact {

/// A point on the skin (layer 0): a triangle and the weights of its three corners.
struct SkinPoint {
  int32_t face = -1;                                      ///< row of model.layers[0].F; -1 = none
  Eigen::Vector3d barycentric = Eigen::Vector3d::Zero();  ///< weights of F(face, 0..2), sum 1
  Eigen::Vector3d point_mm = Eigen::Vector3d::Zero();     ///< at positions x
  double distance_mm = std::numeric_limits<double>::infinity();  ///< from the query point
};

/// The point of the skin's triangles nearest to `p` at positions x. Brute force with a box
/// reject per triangle: the skin moves every step, so a search tree would be rebuilt per query.
SkinPoint closest_skin_point(const Model& model, const Eigen::MatrixX3d& x,
                             const Eigen::Vector3d& p);

/// How far `p` is under the skin at positions x, mm: the distance to the nearest skin point when
/// p is inside the organ (the skin's winding number at p above 1/2), minus it outside.
double depth_under_skin(const Model& model, const Eigen::MatrixX3d& x, const Eigen::Vector3d& p);

/// How far under the skin a tool of radius `radius_mm` may start: its radius (a press: the
/// sphere or patch still reaches the skin from outside) or 1 mm (a point picked on the skin and
/// rounded), whichever is more. Deeper it starts inside the organ, which a tool cannot (refused
/// by name: tools[].point, the tool tip).
inline double start_depth_limit_mm(double radius_mm) {
  return radius_mm > 1.0 ? radius_mm : 1.0;
}

/// Skin node `node` as a SkinPoint (one of its triangles, weight 1 on it).
/// \note Throws lamina::Error (kInvalidInput) when `node` is not a skin node.
SkinPoint skin_point_at_node(const Model& model, const Eigen::MatrixX3d& x, int32_t node);

/// A force held at a skin point, spread over the skin within `radius_mm` of it with a pressure
/// falling as 1 - (d / radius)^2 (a rounded probe's), each piece of skin passing its share to
/// its triangle's corners by barycentric weights. Only skin facing the same way as the contact
/// triangle shares it (not the far side of a thin edge). radius 0: the contact point's own
/// weights. The forces sum to `force_mn` exactly (to rounding).
ForceRoute spread_on_patch(const Model& model, const Eigen::MatrixX3d& x, const SkinPoint& at,
                           const Eigen::Vector3d& force_mn, double radius_mm);

/// A rigid sphere pressing the skin (press_sphere(): a penalty per unit area, frictionless),
/// each pressed piece passing its force to its triangle's corners by barycentric weights. The
/// forces sum to the pieces' total (the tissue's load; the sphere feels minus it). Empty (no
/// nodes) when the sphere does not reach the skin. `lamina validate`'s tool case drives it
/// against finite elements pressed by the same law.
ForceRoute sphere_contact(const Model& model, const Eigen::MatrixX3d& x,
                          const PressingSphere& sphere);

}  // namespace lamina::interact
