#pragma once
/// \file
/// Dissection: a blade drawn through a world that divides the attachments' ties it passes
/// (world::divide_ties), at the bodies' current positions, as a scalpel divides the connective
/// tissue between two organs. A scene's dissections move with the world's clock; a user's
/// stroke (the viewer's, a script's) is swept at once.

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "lamina/interact/scalpel.h"
#include "lamina/world/attachment.h"

namespace lamina::world {

class World;

/// A blade that divides the ties within `reach_mm` of where it passes. It does not cut the
/// bodies' tetrahedra (a body's scalpel in a world is refused).
struct Dissection {
  interact::Scalpel blade;
  double reach_mm = 1.5;
};

/// The surface the edge of `blade` sweeps from `from_s` to `to_s` (each clamped to the blade's
/// start and end): its upper end moving along the path at constant speed, its lower end
/// depth_mm along its direction, mm.
BladeSweep blade_sweep(const interact::Scalpel& blade, double from_s, double to_s);

/// Moves the dissections' blades from `from_s` to `to_s` (a step) and divides the ties each
/// passes (divide_ties at its reach).
/// @return the ties divided
int32_t advance_dissections(const std::vector<Dissection>& dissections, World& world, double from_s,
                            double to_s);

/// Refuses a stroke whose blade a scalpel could not be (model::blade_problem: fewer than two
/// finite points, a path of no length, a depth that is not positive, a direction that is not
/// finite and non-zero or runs along the path) or whose reach is not a positive number.
/// \note Throws lamina::Error (kInvalidInput) "WHAT: KEY: problem".
void check_stroke(const std::string& what, const std::vector<Eigen::Vector3d>& path,
                  const Eigen::Vector3d& direction, double depth_mm, double reach_mm);

/// A stroke swept at once: the blade's upper end along every segment of `path`, its lower end
/// `depth_mm` along `direction`; divides the ties within `reach_mm` of the surface.
/// @return the ties divided
int32_t dissect_along(World& world, const std::vector<Eigen::Vector3d>& path,
                      const Eigen::Vector3d& direction, double depth_mm, double reach_mm);

}  // namespace lamina::world
