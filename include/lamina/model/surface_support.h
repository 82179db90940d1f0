#pragma once
/// \file
/// An elastic support of part of the organ's surface: what holds a liver in the body (its bare
/// area against the diaphragm, its ligaments and veins, the organs around it) is not a clamp.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "lamina/model/model.h"

namespace lamina::model {

/// Which part of the skin is supported, and how stiffly.
struct SurfaceSupportOptions {
  /// The supported side faces this way (any length): in LPS, +y is posterior (the liver's back,
  /// against the diaphragm and the posterior abdominal wall).
  Eigen::Vector3d direction = Eigen::Vector3d::UnitY();
  /// Skin whose outward normal at rest is within this angle of `direction`, degrees.
  double max_angle_deg = 60.0;
  /// Pressure per millimetre of displacement, kPa/mm (= mN/mm^3): a Winkler foundation. Tissue of
  /// modulus E and thickness t behind the surface gives about E / t (liver-like tissue, 6 kPa,
  /// 12 mm: 0.5 kPa/mm).
  double stiffness_kpa_per_mm = 0.5;
};

/// The supported skin nodes and each one's spring to its rest position.
struct SurfaceSupport {
  std::vector<int32_t> nodes;             ///< skin nodes, ascending
  std::vector<double> stiffness_n_per_m;  ///< per node: stiffness x its area (a third of each
                                          ///< incident skin triangle), N/m = mN/mm
  double area_mm2 = 0.0;                  ///< total supported area
};

/// Selects the skin nodes facing `options.direction` and gives each a share of the support.
/// @param[in] model    rest positions and the skin (layer 0)
/// @param[in] options  side, angle and stiffness per area
/// \note Throws lamina::Error (kInvalidInput) naming the option for a zero direction, an angle
///   outside [0, 180] or a negative or non-finite stiffness.
SurfaceSupport surface_support(const Model& model, const SurfaceSupportOptions& options);

}  // namespace lamina::model
