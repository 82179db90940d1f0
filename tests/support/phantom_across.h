#pragma once
// A scalpel across the small tetrahedral phantom (tet_phantom.h) and the phantom held at its
// back, stepped by implicit Euler: what the scalpel's tests (interact) and the one-organ loop's
// cut tests (world) cut.

#include <Eigen/Core>

#include "lamina/interact/scalpel.h"
#include "lamina/sim/simulation.h"
#include "support/tet_phantom.h"

namespace lamina::test {

struct Across {
  Eigen::Vector3d lo, hi;
  double x0 = 0.0;
  interact::Scalpel scalpel;
};

/// A cut across the phantom at x = x0, from its front to its back, through its whole depth.
inline Across across() {
  const Model& m = tet_phantom();
  Across s;
  s.lo = m.X.colwise().minCoeff();
  s.hi = m.X.colwise().maxCoeff();
  s.x0 = m.X.col(0).mean() + 0.31;
  s.scalpel.path = {Eigen::Vector3d(s.x0, s.lo.y() - 5, s.lo.z() - 5),
                    Eigen::Vector3d(s.x0, s.hi.y() + 5, s.lo.z() - 5)};
  s.scalpel.depth_direction = Eigen::Vector3d::UnitZ();
  s.scalpel.depth_mm = s.hi.z() - s.lo.z() + 10;
  s.scalpel.start_s = 0.0;
  s.scalpel.end_s = 0.1;
  return s;
}

/// The phantom's physical liver, its posterior 15 mm held.
inline sim::Simulation held_phantom() {
  sim::Simulation s = sim::make_simulation(tet_phantom(), kTetLiver,
                                           {.integrator = sim::Integrator::kImplicitEuler});
  sim::fix_nodes(s, posterior_nodes(tet_phantom()));
  return s;
}

}  // namespace lamina::test
