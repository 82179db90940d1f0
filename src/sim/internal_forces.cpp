// The internal forces and energies at any positions, over the whole model: for tests,
// validation, the reaction force on a tool and benchmarks (not the step's hot path, which
// visits only what moves).
#include <Eigen/Geometry>
#include <algorithm>

#include "solver.h"
#include "spring_kernel.h"

namespace lamina::sim {

using namespace detail;

void spring_forces(Simulation& sim, const Eigen::MatrixX3d& x, Eigen::MatrixX3d& f) {
  // Every spring, not only the active ones: this is the whole model's force at any x.
  Solver& s = sim.solver();
  const Springs& sp = s.model->springs;
  const auto springs = static_cast<int64_t>(sp.size());
  const int T = threads_for_springs(springs);
  const ConstCols p(x);
  Cols fs(s.springs.force);
  for_slices(springs, T, [&](int64_t begin, int64_t end, int) {
    spring_kernel<double>(begin, end, nullptr, sp.i.data(), sp.j.data(), sp.rest_length_mm.data(),
                          s.springs.stiffness_n_per_m.data(), p.x, p.y, p.z, fs.x, fs.y, fs.z);
  });
  for_slices(x.rows(), T, [&](int64_t begin, int64_t end, int) {
    for (int64_t i = begin; i < end; ++i) {
      double fx = 0.0, fy = 0.0, fz = 0.0;
      gather_springs(s, static_cast<int32_t>(i), fx, fy, fz);
      f(i, 0) += fx, f(i, 1) += fy, f(i, 2) += fz;
    }
  });
}

void internal_forces(Simulation& sim, const Eigen::MatrixX3d& x, Eigen::MatrixX3d& f) {
  const Solver& s = sim.solver();
  if (!s.tets.on) spring_forces(sim, x, f);  // else the tetrahedra carry the springs
  tet_forces(s, x, f);
  volume_forces(s, x, f);
  for (Eigen::Index i = 0; i < x.rows(); ++i)
    f.row(i) -=
        s.support.stiffness_n_per_m[static_cast<size_t>(i)] * (x.row(i) - s.model->X.row(i));
}

Eigen::Vector3d internal_force_on(const Simulation& sim, const std::vector<int32_t>& nodes) {
  const Solver& s = sim.solver();
  const Model& m = *s.model;
  const Eigen::MatrixX3d& x = sim.x;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int32_t i : nodes) {
    for (int32_t a = s.springs.adj_offsets[i]; !s.tets.on && a < s.springs.adj_offsets[i + 1];
         ++a) {
      const int32_t j = s.springs.adj_other[a], e = s.springs.adj_spring[a];
      const Eigen::Vector3d d = x.row(j) - x.row(i);
      const double len = d.norm();
      if (len > 1e-12)
        sum += s.springs.stiffness_n_per_m[e] * (len - m.springs.rest_length_mm[e]) * (d / len);
    }
    sum -= s.support.stiffness_n_per_m[i] * (x.row(i) - m.X.row(i)).transpose();
    if (s.material.volume_stiffness_kpa > 0.0) {
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
  return spring_energy_mj(sim.solver(), x) * 1e-6;
}

double elastic_energy(const Simulation& sim, const Eigen::MatrixX3d& x) {
  const Solver& s = sim.solver();
  return ((s.tets.on ? 0.0 : spring_energy_mj(s, x)) + tet_energy_mj(s, x) +
          support_energy_mj(s, x) + volume_energy_mj(s, x)) *
         1e-6;  // mN mm = 1e-6 J
}

}  // namespace lamina::sim
