// Semi-implicit Euler's stability limit by Gershgorin's bound on each node's row of M^-1 K.
//
// Gershgorin is far below the rest stiffness's true limit on physical tetrahedra (13x on the
// TotalSegmentator liver: 49 us against 630 us from the largest eigenvalue), but a limit taken
// from the rest eigenvalue, even with a 1.5 margin, blew up the stability suite's 30%
// indentation of the phantom at dt = 1 ms (compressed tetrahedra stiffen, up to 100x under the
// inversion guard, which neither bound sees). Gershgorin's slack is what carries those cases,
// so it stays (docs/physics.md).
#include <algorithm>
#include <cmath>
#include <limits>

#include "force_terms.h"
#include "solver.h"

namespace lamina::sim {

double explicit_dt_limit(const Simulation& sim) {
  const detail::Solver& s = sim.solver();
  const Model& m = *s.model;
  // Each node's own limit depends only on the stiffness, masses and damping: cached for them,
  // as an indenter holds new positions (a new setup) every step and the rows cost a pass over
  // every tetrahedron; which nodes are held is applied below.
  if (s.row_limit_version != s.stiffness_version) {
    std::vector<double> row(static_cast<size_t>(m.node_count()), 0.0);  // N/m
    for_each_term(detail::Terms{}, s,
                  [&](auto term) { decltype(term)::add_stiffness_rows(s, row); });
    s.row_limit_s.assign(static_cast<size_t>(m.node_count()),
                         std::numeric_limits<double>::infinity());
    for (int32_t i = 0; i < m.node_count(); ++i) {
      if (row[i] <= 0.0) continue;
      const double w2 = row[i] / s.mass_kg[i];
      const double c = s.material.damping_kg_per_s / s.mass_kg[i] + s.material.mass_damping_per_s;
      s.row_limit_s[i] = (std::sqrt(c * c + 4.0 * w2) - c) / w2;  // root of w2 h^2 + 2ch = 4
    }
    s.row_limit_version = s.stiffness_version;
  }
  double limit = std::numeric_limits<double>::infinity();
  for (int32_t i = 0; i < m.node_count(); ++i)
    if (!s.fixed[i]) limit = std::min(limit, s.row_limit_s[i]);
  return limit;
}

}  // namespace lamina::sim
