// How much of an implicit step to take so that no tetrahedron collapses in it. Implicit Euler
// solves the system linearised at the step's start: under a load concentrated on a fine mesh
// (three 0.3 N tools on a 9,064-node liver 20 mm thick) its answer moved a patch 31 mm in one
// 10 ms step and inverted tetrahedra, which the next linearisation could not undo, and the
// organ blew up. A line search along the step, as inversion-free solvers (IPC, projective
// dynamics' line searches) do: the step is scaled so that every tetrahedron keeps at least a
// fifth of the volume it had; the tetrahedra's guard (tet_term.cpp) then pushes back in the next
// steps. A step that collapses nothing, every step of ordinary motion, is taken whole.
#include <Eigen/Geometry>
#include <algorithm>
#include <array>

#include "solver.h"

namespace lamina::sim::detail {
namespace {

// What a tetrahedron may shrink to in one step, of its volume at the step's start.
constexpr double kKeptVolume = 0.2;

double det(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  return a.cross(b).dot(c);
}

}  // namespace

double volume_keeping_fraction(const Solver& s, const Eigen::MatrixX3d& x,
                               const Eigen::MatrixX3d& v1, double h, int threads) {
  if (s.active_tets.empty()) return 1.0;
  const Eigen::MatrixX4i& T = s.model->tets.T;
  const int64_t n = static_cast<int64_t>(s.active_tets.size()), tets = T.rows();
  std::array<double, kMaxThreads> fraction;
  fraction.fill(1.0);
  for_slices(n, threads, [&](int64_t begin, int64_t end, int t) {
    double alpha_min = 1.0;
    for (int64_t q = begin; q < end; ++q)  // blocks of kTetLanes tetrahedra
      for (int64_t e = int64_t{s.active_tets[static_cast<size_t>(q)]} * kTetLanes,
                   last = std::min(e + kTetLanes, tets);
           e < last; ++e) {
        std::array<Eigen::Vector3d, 4> p, u;
        for (int c = 0; c < 4; ++c) {
          const int32_t i = T(e, c);
          p[c] = x.row(i).transpose();
          u[c] = s.movable[static_cast<size_t>(i)] ? Eigen::Vector3d(h * v1.row(i).transpose())
                                                   : Eigen::Vector3d::Zero();
        }
        const Eigen::Vector3d e1 = p[1] - p[0], e2 = p[2] - p[0], e3 = p[3] - p[0];
        const Eigen::Vector3d d1 = u[1] - u[0], d2 = u[2] - u[0], d3 = u[3] - u[0];
        const double v0 = det(e1, e2, e3);
        if (!(v0 > 0.0)) continue;  // inverted already: the guard's to push back, not this
        const double floor = kKeptVolume * v0;
        // The largest of 1, 1/2, 1/4, ... at which the volume stays above the floor (the volume
        // is a cubic in alpha: a halving search, not its roots, is enough for a safeguard).
        double alpha = alpha_min;  // no tetrahedron needs to look above the smallest so far
        while (alpha > 1.0 / 1024.0 &&
               !(det(e1 + alpha * d1, e2 + alpha * d2, e3 + alpha * d3) >= floor))
          alpha *= 0.5;
        alpha_min = std::min(alpha_min, alpha);
      }
    fraction[static_cast<size_t>(t)] = alpha_min;
  });
  return *std::min_element(fraction.begin(), fraction.begin() + std::max(threads, 1));
}

}  // namespace lamina::sim::detail
