#pragma once
/// \file
/// One indentation solved two ways, so that they can be compared: the mass-spring model's
/// quasi-static answer (a patch of skin held at the indenter, run to rest) and a finite-element
/// answer (the same patch driven, the same region held) on a tet mesh of the same mask.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "lamina/model/model.h"
#include "lamina/sim/simulation.h"
#include "lamina/validate/fem.h"
#include "lamina/validate/tet_mesh.h"

namespace lamina::validate {

/// Where and how the organ is indented, in the model's physical frame (mm).
struct Indentation {
  Eigen::Vector3d contact_mm = Eigen::Vector3d::Zero();  ///< skin point touched, at rest
  Eigen::Vector3d direction = Eigen::Vector3d::UnitY();  ///< unit, into the organ
  double radius_mm = 10.0;      ///< the skin within this distance of the contact moves with the tip
  double organ_depth_mm = 0.0;  ///< the organ's thickness along `direction` from the contact
  /// Held region: every node within `held_distance_mm` of the plane through `held_point_mm`
  /// with normal `held_normal` (the paper's: the posterior 10 mm).
  Eigen::Vector3d held_point_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d held_normal = Eigen::Vector3d::UnitY();
  double held_distance_mm = 10.0;
  /// The tool case (press_mass_spring(), press_fem()): the sphere's pressure per mm of
  /// penetration, kPa/mm (interact::PressingSphere); its radius is `radius_mm`.
  double sphere_stiffness_kpa_per_mm = 1.0;
};

/// The paper's poke as an indentation of `model`: the most anterior skin node (smallest y),
/// pushed posteriorly (+y), the posterior 10 mm held; the organ's depth is the distance to the
/// far side of the skin along that line.
Indentation paper_indentation(const Model& model, double radius_mm = 10.0);

/// Like paper_indentation(), but at the skin node where the organ is deepest along +y (its
/// first exit through the skin), so that a large indentation has room: the paper's anterior-most
/// point can be a thin edge (16.5 mm deep on the TotalSegmentator liver). Tries at most about
/// 400 skin nodes, evenly spread.
Indentation deepest_indentation(const Model& model, double radius_mm = 10.0);

/// One solved indentation.
struct IndentResult {
  Eigen::MatrixX3d skin_u;         ///< displacement at each sample point (skin node), mm
  Eigen::MatrixX3d u;              ///< FEM only: the displacement of every mesh vertex, mm
  double force_n = 0.0;            ///< the indenter's push along `direction`, N
  double volume_change_pct = 0.0;  ///< of the whole organ (mass-spring: the skin's enclosed volume)
  bool converged = false;
  int64_t steps = 0;     ///< mass-spring steps or FEM linear solves
  double seconds = 0.0;  ///< wall time
};

/// Mass-spring: skin nodes within the indenter radius held at X + depth * direction, the held
/// region at rest, stepped to rest (threshold in `solver`, global mode) in `ramp` equal
/// increments of depth.
/// @param[in] model     the model (its springs as they are: identify them first for E and nu)
/// @param[in] material  material (node masses, volume term, damping)
/// @param[in] solver    integrator, dt, threshold, max_steps (mode is forced to global)
IndentResult indent_mass_spring(const Model& model, const sim::Material& material,
                                sim::SolverOptions solver, const Indentation& indentation,
                                double depth_mm, int ramp = 4);

/// Finite elements: boundary vertices within the indenter radius driven by depth * direction,
/// vertices within the held slab fixed; linear, corotational or Neo-Hookean; the displacement
/// sampled at `samples` (rest positions, mm) by the nearest point of the mesh's boundary.
IndentResult indent_fem(const TetMesh& mesh, const FemMaterial& material,
                        const Indentation& indentation, double depth_mm, FemLaw law,
                        const Eigen::MatrixX3d& samples, const FemOptions& options = {});

/// The tool case, mass-spring: a rigid sphere of the indentation's radius comes along
/// `direction` to the contact point and, from where it first touches the rest skin, moves on by
/// `depth_mm` at a steady speed over `travel_s` of simulated time, pressing the skin through the
/// simulation's sphere contact (interact::sphere_contact(), recomputed every step on the current
/// skin), then stays until the model is at rest. The force is the sphere's push along
/// `direction`.
/// \note Throws lamina::Error (kInvalidInput) when the sphere cannot start clear of the skin or
///   never touches it along the line.
IndentResult press_mass_spring(const Model& model, const sim::Material& material,
                               sim::SolverOptions solver, const Indentation& indentation,
                               double depth_mm, double travel_s = 1.0);

/// The tool case, finite elements: the same sphere, law and travel beyond its first touch of the
/// mesh's own rest boundary (FemBoundary::sphere), the held slab fixed; corotational or
/// Neo-Hookean.
IndentResult press_fem(const TetMesh& mesh, const FemMaterial& material,
                       const Indentation& indentation, double depth_mm, FemLaw law,
                       const Eigen::MatrixX3d& samples, const FemOptions& options = {});

/// The displacement field u of `mesh` at each point of `samples` (rest positions, mm): its value
/// at the nearest point of the mesh's boundary (barycentric on the boundary triangle).
Eigen::MatrixX3d sample_on_boundary(const TetMesh& mesh, const Eigen::MatrixX3d& u,
                                    const Eigen::MatrixX3d& samples);

/// RMS and largest distance between two displacement fields (rows matched), mm.
struct FieldError {
  double rms_mm = 0.0, max_mm = 0.0;
  double reference_max_mm = 0.0;  ///< largest displacement of the reference field
};
FieldError field_error(const Eigen::MatrixX3d& u, const Eigen::MatrixX3d& reference);

}  // namespace lamina::validate
