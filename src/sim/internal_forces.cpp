// The internal forces and energies at any positions, over the whole model: for tests,
// validation, the reaction force on a tool and benchmarks (not the step's hot path, which
// visits only what moves).
#include <Eigen/Geometry>
#include <algorithm>

#include "force_terms.h"
#include "solver.h"

namespace lamina::sim {

using namespace detail;

void spring_forces(Simulation& sim, const Eigen::MatrixX3d& x, Eigen::MatrixX3d& f) {
  EdgeSprings::forces(sim.solver(), x, f);  // every spring, whether the tetrahedra carry them
}

void internal_forces(Simulation& sim, const Eigen::MatrixX3d& x, Eigen::MatrixX3d& f) {
  Solver& s = sim.solver();
  for_each_term(Terms{}, s, [&](auto term) { decltype(term)::forces(s, x, f); });
}

Eigen::Vector3d internal_force_on(const Simulation& sim, const std::vector<int32_t>& nodes) {
  const Solver& s = sim.solver();
  const Model& m = *s.model;
  const Eigen::MatrixX3d& x = sim.x;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int32_t i : nodes) {
    for (int32_t a = s.springs.adj_offsets[i];
         EdgeSprings::on(s) && a < s.springs.adj_offsets[i + 1]; ++a) {
      const int32_t j = s.springs.adj_other[a], e = s.springs.adj_spring[a];
      const Eigen::Vector3d d = x.row(j) - x.row(i);
      const double len = d.norm();
      if (len > 1e-12)
        sum += s.springs.stiffness_n_per_m[e] * (len - m.springs.rest_length_mm[e]) * (d / len);
    }
    sum -= s.support.stiffness_n_per_m[i] * (x.row(i) - m.X.row(i)).transpose();
    if (LayerVolume::on(s)) {
      double fx = 0.0, fy = 0.0, fz = 0.0;
      add_volume_force(s, i, fx, fy, fz);  // the pressures of the last step
      sum += Eigen::Vector3d(fx, fy, fz);
    }
  }
  if (s.tets.on) {
    // The tetrahedra's forces of the last step (at its start): one gather per node instead of
    // evaluating each incident tetrahedron again, which a haptic loop asking every few steps
    // could not afford. Before any step, at rest, they are zero.
    std::vector<int32_t> sorted(nodes);
    std::sort(sorted.begin(), sorted.end());
    sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
    for (int32_t i : sorted) {
      double fx = 0.0, fy = 0.0, fz = 0.0;
      gather_tets(s, s.tets.force, i, fx, fy, fz);
      sum += Eigen::Vector3d(fx, fy, fz);
    }
  }
  return sum;
}

void implicit_system_product(Simulation& sim, double h, const Eigen::MatrixX3d& p,
                             Eigen::MatrixX3d& y) {
  Solver& s = sim.solver();
  for (int32_t i = 0; i < s.model->node_count(); ++i)
    if (!s.movable[i]) y.row(i).setZero();
  system_product(s, h, p, y, threads_for(s));
}

double spring_energy(const Simulation& sim, const Eigen::MatrixX3d& x) {
  return EdgeSprings::energy_mj(sim.solver(), x) * 1e-6;
}

double elastic_energy(const Simulation& sim, const Eigen::MatrixX3d& x) {
  const Solver& s = sim.solver();
  double e = 0.0;
  for_each_term(Terms{}, s, [&](auto term) { e += decltype(term)::energy_mj(s, x); });
  return e * 1e-6;  // mN mm = 1e-6 J
}

}  // namespace lamina::sim
