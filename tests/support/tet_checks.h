#pragma once
// Checks the tests of the tetrahedra's energies share (tet_term_test.cpp, neo_hookean_test.cpp).

#include <gtest/gtest.h>

#include <initializer_list>

#include "lamina/sim/simulation.h"

namespace lamina::test {

/// Each listed node's force at x is minus the elastic energy's gradient (central differences),
/// to 1e-5 of the largest force `scale`.
inline void expect_forces_are_minus_the_energy_gradient(const sim::Simulation& s,
                                                        const Eigen::MatrixX3d& x,
                                                        const Eigen::MatrixX3d& f, double scale,
                                                        std::initializer_list<int> nodes) {
  for (int node : nodes)
    for (int c = 0; c < 3; ++c) {
      Eigen::MatrixX3d xp = x, xm = x;
      const double h = 1e-5;
      xp(node, c) += h;
      xm(node, c) -= h;
      const double grad = (sim::elastic_energy(s, xp) - sim::elastic_energy(s, xm)) / (2 * h) * 1e6;
      EXPECT_NEAR(f(node, c), -grad, 1e-5 * scale) << "node " << node << " axis " << c;
    }
}

/// An interior node of `m` mirrored through the face opposite it in its first all-interior
/// tetrahedron: that tetrahedron inverts while its edge lengths barely change.
inline Eigen::MatrixX3d mirror_an_interior_node(const Model& m) {
  Eigen::Index t = 0;
  while (m.tets.T.row(t).maxCoeff() < m.surface_node_count()) ++t;
  int c = 0;
  while (m.tets.T(t, c) < m.surface_node_count()) ++c;
  const int32_t node = m.tets.T(t, c);
  Eigen::RowVector3d centroid = Eigen::RowVector3d::Zero();
  for (int k = 0; k < 4; ++k)
    if (k != c) centroid += m.X.row(m.tets.T(t, k)) / 3.0;
  Eigen::MatrixX3d x = m.X;
  x.row(node) = 2.0 * centroid - m.X.row(node);
  return x;
}

}  // namespace lamina::test
