// The force-term contract (src/sim/force_terms.h), term by term, on every configuration a model
// takes: the paper's springs, the coupled-spring tetrahedra and the Neo-Hookean ones, each with
// the volume term between layers and anchors. Whatever a term computes, its parts must agree:
// forces are minus its energy's gradient, its rest stiffness is its forces' derivative at rest,
// its explicit-limit rows cover its own diagonal, and only the support pushes the organ as a
// whole.
#include "sim/force_terms.h"  // white box: the terms one by one

#include <gtest/gtest.h>

#include <string>

#include "lamina/sim/simulation.h"
#include "sim/block_rows.h"
#include "sim/solver.h"
#include "support/random_rows.h"
#include "support/tet_phantom.h"

namespace {

using namespace lamina;
using sim::detail::Solver;

struct Configuration {
  std::string name;
  sim::Material material;
};

std::vector<Configuration> configurations() {
  sim::Material springs;  // the paper's constants
  sim::Material coupled = test::kTetLiver;
  sim::Material neo = test::kTetLiver;
  neo.tet_model = sim::TetModel::kNeoHookean;
  std::vector<Configuration> out = {
      {"springs", springs}, {"coupled", coupled}, {"neo_hookean", neo}};
  for (Configuration& c : out) {
    c.material.volume_stiffness_kpa = 5.0;
    c.material.anchor_stiffness_n_per_m = 0.5;
  }
  return out;
}

template <class Term>
Eigen::MatrixX3d term_forces(Solver& s, const Eigen::MatrixX3d& x) {
  Eigen::MatrixX3d f = Eigen::MatrixX3d::Zero(x.rows(), 3);
  Term::forces(s, x, f);
  return f;
}

template <class Term>
void check_term(const std::string& where, sim::Simulation& sim) {
  SCOPED_TRACE(where);
  Solver& s = sim.solver();
  const Model& m = sim.model();
  const Eigen::MatrixX3d x = test::jiggle(m.X, 1.0, 11);

  // Forces are minus the energy's gradient (central differences, mN mm per mm).
  const Eigen::MatrixX3d f = term_forces<Term>(s, x);
  const double scale = f.cwiseAbs().maxCoeff();
  ASSERT_GT(scale, 0.0) << "a term that is on exerts no force at a jiggled state";
  for (const int32_t node : {0, 17, m.surface_node_count() - 1, m.node_count() - 1})
    for (int c = 0; c < 3; ++c) {
      Eigen::MatrixX3d xp = x, xm = x;
      const double h = 1e-5;
      xp(node, c) += h, xm(node, c) -= h;
      const double grad = (Term::energy_mj(s, xp) - Term::energy_mj(s, xm)) / (2.0 * h);
      EXPECT_NEAR(f(node, c), -grad, 1e-5 * scale) << "node " << node << " axis " << c;
    }
  // Internal forces do not push the organ as a whole; the support ties it to its rest place.
  if (!std::is_same_v<Term, sim::detail::NodeSupport>)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(f.col(c).sum(), 0.0, 1e-9 * scale) << "axis " << c;

  // The stiffness at rest, every node a row: K p is the forces' derivative along p at rest.
  std::vector<int32_t> row(static_cast<size_t>(m.node_count()));
  for (int32_t i = 0; i < m.node_count(); ++i) row[static_cast<size_t>(i)] = i;
  sim::detail::BlockRows blocks;
  sim::detail::spring_block_pattern(m, row, m.node_count(), blocks);
  Term::add_rest_stiffness(s, row, blocks);
  const sim::detail::SparseRows K = sim::detail::to_sparse(blocks);
  std::vector<double> rows(static_cast<size_t>(m.node_count()), 0.0);
  Term::add_stiffness_rows(s, rows);
  if (std::is_same_v<Term, sim::detail::LayerVolume>) {
    // Left out of the rest stiffness by design (force_terms.h); its rows still bound the step.
    EXPECT_EQ(K.coeffs().cwiseAbs().maxCoeff(), 0.0);
    EXPECT_GT(*std::max_element(rows.begin(), rows.end()), 0.0);
    return;
  }
  const Eigen::MatrixX3d p = test::random_rows(m.node_count(), 1.0, 5);
  const double e = 1e-5;
  const Eigen::MatrixX3d fd =
      -(term_forces<Term>(s, m.X + e * p) - term_forces<Term>(s, m.X - e * p)) / (2.0 * e);
  Eigen::VectorXd pv(3 * m.node_count());
  for (int32_t i = 0; i < m.node_count(); ++i) pv.segment<3>(3 * i) = p.row(i).transpose();
  const Eigen::VectorXd Kp = K * pv;
  double worst = 0.0;
  for (int32_t i = 0; i < m.node_count(); ++i)
    worst = std::max(worst, (Kp.segment<3>(3 * i) - fd.row(i).transpose()).norm());
  EXPECT_LT(worst, 1e-5 * Kp.cwiseAbs().maxCoeff());

  // The explicit step's rows (N/m) are at least each node's own diagonal entries.
  for (int32_t i = 0; i < m.node_count(); ++i)
    for (int d = 0; d < 3; ++d)
      ASSERT_GE(rows[static_cast<size_t>(i)] * (1.0 + 1e-9), K.coeff(3 * i + d, 3 * i + d))
          << "node " << i << " axis " << d;
}

TEST(ForceTerms, EveryTermsForcesEnergyAndStiffnessAgreeOnEveryConfiguration) {
  const Model& m = test::tet_phantom();
  for (const Configuration& c : configurations()) {
    sim::Simulation s = sim::make_simulation(m, c.material);
    int on = 0, tet_energies = 0;
    sim::detail::for_each_term(sim::detail::Terms{}, s.solver(), [&](auto term) {
      using Term = decltype(term);
      ++on;
      check_term<Term>(c.name + ": " + typeid(Term).name(), s);
    });
    sim::detail::with_tet_energy(s.solver(), [&](auto) { ++tet_energies; });
    // Springs or one energy of the tetrahedra, the volume term, the support.
    EXPECT_EQ(on, 3) << c.name;
    EXPECT_EQ(tet_energies, c.name == "springs" ? 0 : 1) << c.name;
  }
}

TEST(ForceTerms, TheWholeModelsForcesAndEnergyAreTheTermsSums) {
  const Model& m = test::tet_phantom();
  for (const Configuration& c : configurations()) {
    sim::Simulation s = sim::make_simulation(m, c.material);
    const Eigen::MatrixX3d x = test::jiggle(m.X, 1.0, 3);
    Eigen::MatrixX3d whole = Eigen::MatrixX3d::Zero(m.node_count(), 3);
    sim::internal_forces(s, x, whole);
    Eigen::MatrixX3d sum = Eigen::MatrixX3d::Zero(m.node_count(), 3);
    double energy_mj = 0.0;
    sim::detail::for_each_term(sim::detail::Terms{}, s.solver(), [&](auto term) {
      using Term = decltype(term);
      sum += term_forces<Term>(s.solver(), x);
      energy_mj += Term::energy_mj(s.solver(), x);
    });
    EXPECT_LT((whole - sum).cwiseAbs().maxCoeff(), 1e-12 * whole.cwiseAbs().maxCoeff()) << c.name;
    EXPECT_NEAR(sim::elastic_energy(s, x), energy_mj * 1e-6, 1e-12 * energy_mj * 1e-6) << c.name;
  }
}

TEST(ForceTerms, ChangingTheTetrahedraModelInPlaceSwitchesTheEnergy) {
  // set_parameters with another Material::tet_model sets the tetrahedra up again: the forces
  // are the new energy's, the same as a simulation made with it.
  const Model& m = test::tet_phantom();
  const std::vector<Configuration> all = configurations();
  sim::Simulation s = sim::make_simulation(m, all[1].material);
  sim::set_parameters(s, all[2].material, s.options());
  const sim::Simulation fresh = sim::make_simulation(m, all[2].material);
  const Eigen::MatrixX3d x = test::jiggle(m.X, 1.0, 9);
  EXPECT_DOUBLE_EQ(sim::elastic_energy(s, x), sim::elastic_energy(fresh, x));
}

}  // namespace
