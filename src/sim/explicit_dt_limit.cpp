// Semi-implicit Euler's stability limit by Gershgorin's bound on each node's row of M^-1 K.
#include <limits>

#include "solver.h"

namespace lamina::sim {

double explicit_dt_limit(const Simulation& sim) {
  const detail::Solver& s = sim.solver();
  const Model& m = *s.model;
  std::vector<double> row(s.support.stiffness_n_per_m);  // support and anchors, N/m
  const Springs& sp = m.springs;
  for (size_t e = 0; !s.tets.on && e < sp.size(); ++e) {  // else inside the tetrahedra
    row[sp.i[e]] += 2.0 * s.springs.stiffness_n_per_m[e];
    row[sp.j[e]] += 2.0 * s.springs.stiffness_n_per_m[e];
  }
  if (s.material.volume_stiffness_kpa > 0.0) detail::add_volume_stiffness_rows(s, row);
  detail::add_tet_stiffness_rows(s, row);
  double limit = std::numeric_limits<double>::infinity();
  for (int32_t i = 0; i < m.node_count(); ++i) {
    if (s.fixed[i] || row[i] <= 0.0) continue;
    const double w2 = row[i] / s.mass_kg[i];
    const double c = s.material.damping_kg_per_s / s.mass_kg[i] + s.material.mass_damping_per_s;
    limit = std::min(limit, (std::sqrt(c * c + 4.0 * w2) - c) / w2);  // root of w2 h^2 + 2ch = 4
  }
  return limit;
}

}  // namespace lamina::sim
