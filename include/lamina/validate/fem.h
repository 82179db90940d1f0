#pragma once
/// \file
/// Static finite-element reference solutions on a tet mesh (linear tetrahedra, P1), to check
/// the mass-spring model against: small-strain linear elasticity, and corotational elasticity
/// (Mueller et al. 2002, Felippa's element-independent corotational frame; SOFA's
/// TetrahedronFEMForceField "polar"), which is exact for rigid motions and so stays valid under
/// large rotations. Pure Eigen (with interact::press_sphere(), the sphere tool's contact law).
///
/// Units: mm, kPa (= mN/mm^2), mN. Everything is quasi-static: no mass, no time.

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <vector>

#include "lamina/interact/sphere_pressure.h"
#include "lamina/validate/tet_mesh.h"

namespace lamina::validate {

/// An isotropic, homogeneous linear-elastic material.
struct FemMaterial {
  double young_modulus_kpa = 0.0;  ///< E, kPa (= mN/mm^2), > 0 (liver: a few kPa)
  double poisson_ratio = 0.0;      ///< nu, in (-1, 0.5); near 0.5 = nearly incompressible
};

/// The constitutive law of a nonlinear solve (and of indent_fem()).
enum class FemLaw : uint8_t {
  kLinear,        ///< small-strain linear elasticity (solve_linear())
  kCorotational,  ///< linear elasticity in each element's rotated frame (solve_corotational())
  kNeoHookean,    ///< stable Neo-Hookean (solve_neo_hookean())
};

/// Loads and supports. A node is either free, fixed, or driven (not both fixed and driven).
struct FemBoundary {
  std::vector<int32_t> fixed;   ///< nodes held at their rest position (all three components)
  std::vector<int32_t> driven;  ///< nodes moved by a prescribed displacement
  Eigen::MatrixX3d driven_displacement_mm;  ///< #driven by 3, displacement of each driven node
  /// Optional, #driven by 3: which components of each driven node are prescribed. Empty = all.
  /// A component left out is free, which makes rollers: a face pushed along x that may still
  /// slide (and contract) in y and z. Its entry in driven_displacement_mm is ignored.
  Eigen::Array<bool, Eigen::Dynamic, 3> driven_mask;
  Eigen::MatrixX3d nodal_force_mn;  ///< #V by 3 external force on each node, mN; or empty
  /// Optional: a rigid, frictionless sphere pressing the mesh's boundary faces by the same
  /// penalty per unit area as the simulation's sphere tool (interact::press_sphere()). Its
  /// centre moves from `sphere_start_mm` to `sphere->center_mm` in equal parts over the load
  /// steps (nonlinear solves only). The tangent adds each pressed piece's normal stiffness, and
  /// its sideways softening (the force turning with the normal) once the relative residual is
  /// below 1e-3. FemResult::converged then means the last load step reached the tolerance.
  std::optional<interact::PressingSphere> sphere;
  Eigen::Vector3d sphere_start_mm = Eigen::Vector3d::Zero();
};

/// Options of the nonlinear (corotational) solve.
struct FemOptions {
  /// The prescribed displacements and forces are applied in this many equal increments, each
  /// solved to `tolerance` before the next, so that no element inverts in a single step.
  int load_steps = 10;
  int max_newton_iterations = 30;  ///< per load step
  /// On the relative residual: |out-of-balance force on the free components| over the largest
  /// |internal force| + |external force| (all components) met so far in the solve. Not the
  /// current forces: those vanish, and the ratio with them, as a body nears a rigid motion.
  double tolerance = 1e-8;
};

/// A static equilibrium.
struct FemResult {
  Eigen::MatrixX3d u;  ///< #V by 3 displacement, mm
  /// #V by 3 reaction, mN: at each constrained component, internal elastic force minus external
  /// load (K u - f for the linear model), i.e. the force the support must apply to the node to
  /// hold it there. The solid pulls on the support with the opposite force: stretching a bar
  /// along +x by its +x end gives +E A strain summed over that end. Zero on free components.
  Eigen::MatrixX3d reaction_mn;
  int iterations = 0;       ///< linear solves made (all load steps together)
  double residual = 0.0;    ///< final relative residual (see FemOptions::tolerance)
  bool converged = false;   ///< every load step reached the tolerance, and the result is finite
  double volume_mm3 = 0.0;  ///< deformed volume, tet_volume(mesh, V + u)
  /// With FemBoundary::sphere: the sphere's push on the body at the end, mN (it feels minus it).
  Eigen::Vector3d sphere_push_mn = Eigen::Vector3d::Zero();
};

/// Small-strain linear elasticity: solves K u = f with the Dirichlet components eliminated
/// (sparse LDLT; conjugate gradients if the factorisation fails).
/// @param[in] mesh      rest mesh (positively oriented tets)
/// @param[in] material  E and nu
/// @param[in] boundary  supports, prescribed displacements and nodal forces
/// @return displacement and reactions; `iterations` = 1, converged when the relative residual
///   is below 1e-8
/// \note Nodes used by no tet have no stiffness: they are left at their prescribed (or zero)
///   displacement and a force on them is an error.
/// \throws lamina::Error (kInvalidInput) for invalid material, a bad index, non-finite or
///   mis-sized input, an inverted or flat rest tet, no constraint at all, or a sphere (contact
///   is nonlinear: solve_corotational() or solve_neo_hookean())
FemResult solve_linear(const TetMesh& mesh, const FemMaterial& material,
                       const FemBoundary& boundary);

/// Corotational linear elasticity: each element's stiffness acts in its own rotated frame,
/// f_e = R K_e (R^T x - X), with R the rotation of the polar decomposition of the element's
/// deformation gradient. Exactly zero force for any rigid motion, and the linear model's
/// answer for small strains. Loads are ramped over `options.load_steps`; each step is solved by
/// Newton-like iterations with the tangent R K_e R^T (the rotation's own derivative is left
/// out, so convergence is linear rather than quadratic under large rotations).
/// @param[in] mesh      rest mesh
/// @param[in] material  E and nu (a linear material in the rotated frame: volume is not exactly
///   kept even for nu near 0.5 at large strain)
/// @param[in] boundary  as for solve_linear()
/// @param[in] options   load steps, iterations, tolerance
/// @return the last iterate; `converged` is false if any load step missed the tolerance (the
///   remaining steps are still solved) or a non-finite value appeared (the solve stops there)
/// \throws lamina::Error (kInvalidInput) as solve_linear(), and for options out of range
FemResult solve_corotational(const TetMesh& mesh, const FemMaterial& material,
                             const FemBoundary& boundary, const FemOptions& options);

/// Stable Neo-Hookean (Smith, de Goes & Kim 2018): per element mu/2 (tr C - 3) +
/// lambda'/2 (J - alpha)^2 with lambda' = lambda + mu, alpha = 1 + mu / lambda' (linear
/// elasticity at small strain; the simulation's Material::tet_model kNeoHookean without its
/// inversion guard). Same load steps and Newton-like iterations as solve_corotational(), on each
/// element's exact tangent projected to positive semi-definite (its negative eigenvalues set to
/// zero: projected Newton).
/// @return, \throws as solve_corotational()
FemResult solve_neo_hookean(const TetMesh& mesh, const FemMaterial& material,
                            const FemBoundary& boundary, const FemOptions& options);

}  // namespace lamina::validate
