// The reference loop of `lamina bench`: deliberately plain (see plain_loop.h). Its only duty
// besides being plain is to compute what sim::step computes, which a test holds.
#include "plain_loop.h"

#include <algorithm>
#include <cmath>

#include "lamina/core/error.h"

namespace lamina::cli {

PlainLoop make_plain_loop(const sim::Simulation& sim) {
  const Model& m = sim.model();
  const sim::Material& mat = sim.material();
  const auto refuse = [](const char* what) {
    throw Error(ErrorKind::kInvalidInput, std::string("plain loop: ") + what);
  };
  if (mat.young_modulus_kpa > 0.0 || mat.volume_stiffness_kpa > 0.0)
    refuse("models springs only (no tetrahedra, no volume term)");
  if (mat.anchor_stiffness_n_per_m > 0.0) refuse("has no support or anchor springs");
  if (sim.options().mode == sim::Mode::kLocal) refuse("runs the global mode only");
  if (sim.options().integrator != sim::Integrator::kSemiImplicitEuler)
    refuse("is semi-implicit Euler only");
  if (sim::explicit_substeps(sim.options().dt_s, sim::explicit_dt_limit(sim)) > 1)
    refuse("has no substeps: dt is beyond the explicit limit");
  PlainLoop p;
  const int32_t n = m.node_count();
  p.dt_s = sim.options().dt_s;
  p.x.resize(3 * static_cast<size_t>(n));
  p.v.resize(p.x.size());
  p.f.assign(p.x.size(), 0.0);
  p.f_other.resize(p.x.size());
  p.h_over_m.resize(static_cast<size_t>(n));
  p.damping.resize(static_cast<size_t>(n));
  for (int32_t i = 0; i < n; ++i) {
    const double mass = sim.mass_kg()[i];
    for (int d = 0; d < 3; ++d) {
      p.x[3 * i + d] = sim.x(i, d);
      p.v[3 * i + d] = sim.movable()[i] ? sim.v(i, d) : 0.0;  // so a fixed node stays put
      p.f_other[3 * i + d] = sim.f_ext(i, d) + mass * mat.gravity_mm_per_s2[d];
    }
    p.h_over_m[i] = sim.movable()[i] ? p.dt_s / mass : 0.0;
    p.damping[i] = mat.damping_kg_per_s + mat.mass_damping_per_s * mass;
  }
  p.si = m.springs.i;
  p.sj = m.springs.j;
  p.rest_mm = m.springs.rest_length_mm;
  p.k_n_per_m = sim.spring_stiffness_n_per_m();
  return p;
}

void plain_step(PlainLoop& p) {
  double* x = p.x.data();
  double* f = p.f.data();
  for (size_t e = 0; e < p.si.size(); ++e) {
    const int32_t a = p.si[e], b = p.sj[e];
    const double dx = x[3 * b] - x[3 * a], dy = x[3 * b + 1] - x[3 * a + 1],
                 dz = x[3 * b + 2] - x[3 * a + 2];
    const double l = std::max(std::sqrt(dx * dx + dy * dy + dz * dz), 1e-12);
    const double t = p.k_n_per_m[e] * (l - p.rest_mm[e]) / l;
    f[3 * a] += t * dx, f[3 * a + 1] += t * dy, f[3 * a + 2] += t * dz;
    f[3 * b] -= t * dx, f[3 * b + 1] -= t * dy, f[3 * b + 2] -= t * dz;
  }
  const size_t n = p.h_over_m.size();
  for (size_t i = 0; i < n; ++i) {
    for (size_t d = 3 * i; d < 3 * i + 3; ++d) {
      p.v[d] += p.h_over_m[i] * (f[d] + p.f_other[d] - p.damping[i] * p.v[d]);
      x[d] += p.dt_s * p.v[d];
      f[d] = 0.0;
    }
  }
}

}  // namespace lamina::cli
