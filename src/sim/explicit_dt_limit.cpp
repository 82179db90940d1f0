// Semi-implicit Euler's stability limit: h^2 w^2 + 2 h c < 4 for the fastest mode w and the
// strongest damping c. w comes from the rest stiffness's largest eigenvalue (power iteration,
// highest_angular_frequency) with a margin, plus the volume term's Gershgorin bound; never below
// the all-Gershgorin estimate, which is safe but 5-10x low on physical tetrahedra (every node's
// row of M^-1 K summed in absolute value, each 3x3 block bounded by 2 sqrt 3 of its entries).
#include <algorithm>
#include <cmath>
#include <limits>

#include "solver.h"

namespace lamina::sim {
namespace {

// The power iteration's Rayleigh quotient approaches w^2 from below; the margin covers what
// 300 iterations leave (measured: the quotient settles within 2% on the three livers, docs/
// physics.md) and the stiffening of compressed tetrahedra under a load.
constexpr double kPowerMargin = 1.5;

double limit_for(double w2, double c) {
  return w2 > 0.0 ? (std::sqrt(c * c + 4.0 * w2) - c) / w2 : std::numeric_limits<double>::infinity();
}

}  // namespace

double explicit_dt_limit(const Simulation& sim) {
  const detail::Solver& s = sim.solver();
  const Model& m = *s.model;
  std::vector<double> row(s.support.stiffness_n_per_m);  // support and anchors, N/m
  const Springs& sp = m.springs;
  for (size_t e = 0; !s.tets.on && e < sp.size(); ++e) {  // else inside the tetrahedra
    row[sp.i[e]] += 2.0 * s.springs.stiffness_n_per_m[e];
    row[sp.j[e]] += 2.0 * s.springs.stiffness_n_per_m[e];
  }
  std::vector<double> volume_row(static_cast<size_t>(m.node_count()), 0.0);
  if (s.material.volume_stiffness_kpa > 0.0) detail::add_volume_stiffness_rows(s, volume_row);
  detail::add_tet_stiffness_rows(s, row);
  double gershgorin = std::numeric_limits<double>::infinity();
  double volume_w2 = 0.0, c_max = 0.0;
  for (int32_t i = 0; i < m.node_count(); ++i) {
    if (s.fixed[i]) continue;
    const double c = s.material.damping_kg_per_s / s.mass_kg[i] + s.material.mass_damping_per_s;
    c_max = std::max(c_max, c);
    volume_w2 = std::max(volume_w2, volume_row[i] / s.mass_kg[i]);
    const double w2 = (row[i] + volume_row[i]) / s.mass_kg[i];
    if (w2 > 0.0) gershgorin = std::min(gershgorin, limit_for(w2, c));
  }
  if (s.omega_max2_version != s.stiffness_version) {
    const double w = highest_angular_frequency(sim);
    s.omega_max2 = w * w;
    s.omega_max2_version = s.stiffness_version;
  }
  const double power = limit_for(kPowerMargin * s.omega_max2 + volume_w2, c_max);
  return std::max(gershgorin, power);
}

}  // namespace lamina::sim
