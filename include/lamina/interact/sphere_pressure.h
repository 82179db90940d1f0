#pragma once
/// \file
/// A rigid, frictionless sphere pressing a triangle surface by a penalty per unit area: every
/// piece of the surface inside the sphere is pushed out along the sphere's radius with a
/// pressure that grows with how deep it is (stiffness x (radius - distance from the centre),
/// eased in at the rim).
/// Defined on the surface's area, not on its vertices, so that the same sphere pressing two
/// meshes of one organ (the model's 10 mm skin, a finite-element mesh's 3 mm boundary) applies
/// the same law to both: what `lamina validate`'s tool case compares (docs/validation.md).
/// Pure Eigen: the finite-element reference calls it on its own boundary.

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

namespace lamina::interact {

/// The part of the radius over which the pressure eases in at the sphere's rim (see
/// press_sphere()).
inline constexpr double kSphereRimFraction = 0.05;

/// The sphere. Units: mm, kPa (= mN/mm^2), so the stiffness is mN/mm^3.
struct PressingSphere {
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();
  double radius_mm = 10.0;
  double stiffness_kpa_per_mm = 1.0;  ///< pressure per mm of penetration, > 0
};

/// One pressed piece of the surface: a sample point of a triangle and what acts on it.
struct PressedPiece {
  int32_t face = -1;                                      ///< row of F
  Eigen::Vector3d barycentric = Eigen::Vector3d::Zero();  ///< weights of F(face, 0..2)
  Eigen::Vector3d force_mn = Eigen::Vector3d::Zero();     ///< on the surface, out of the sphere
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();       ///< unit, from the centre to the piece
  /// The force's stiffness along `normal`, mN/mm (the pressure's slope x the piece's area):
  /// moving the piece by dy changes its force by -stiffness n n^T dy, plus
  /// |force| / distance (I - n n^T) dy as the force turns with the normal (a softening a solve
  /// may add near its answer: validate's FEM does), plus the change of the piece's area.
  double stiffness_mn_per_mm = 0.0;
  double distance_mm = 0.0;  ///< from the sphere's centre to the piece, mm
};

/// What is wrong with a sphere's parameters (the field and why), or nothing.
std::optional<std::pair<const char*, const char*>> sphere_problem(const PressingSphere& sphere);

/// The pieces of the surface (positions x, triangles F, rows of F indexing x) inside the sphere,
/// each pushed with pressure k (depth - s/2) for depth (radius - distance from the centre) past
/// s = kSphereRimFraction x radius, and k depth^2 / (2 s) before: the same force beyond the rim
/// band, a slope without a jump where a piece enters the sphere (Newton would cycle on one).
/// Each triangle near the sphere is cut into pieces no wider than radius / 8 on the rest surface
/// `rest` (same rows as x; at most 16 cuts an edge): cuts fixed by the rest shape keep the force
/// continuous as the surface deforms and as the sphere moves, which a Newton solve needs.
/// `pieces` is cleared and refilled: reused, it allocates nothing once it has grown.
void press_sphere(const Eigen::MatrixX3d& x, const Eigen::MatrixX3d& rest,
                  const Eigen::MatrixX3i& F, const PressingSphere& sphere,
                  std::vector<PressedPiece>& pieces);

/// The sum of the pieces' forces: the surface's load; the sphere feels minus it.
Eigen::Vector3d pressed_total(const std::vector<PressedPiece>& pieces);

/// Where a sphere moving from `from_mm` along the unit `direction` first touches the surface
/// (x, F): the centre at that moment. `from_mm` must be clear of the surface (farther than the
/// radius from every triangle); bisection to 1e-9 of the radius. No touch within `travel_mm`:
/// nothing.
std::optional<Eigen::Vector3d> sphere_first_touch(const Eigen::MatrixX3d& x,
                                                  const Eigen::MatrixX3i& F,
                                                  const Eigen::Vector3d& from_mm,
                                                  const Eigen::Vector3d& direction,
                                                  double radius_mm, double travel_mm);

}  // namespace lamina::interact
