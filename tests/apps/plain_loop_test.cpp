// The plain loop `lamina bench` compares against must compute what sim::step computes, or its
// ratio means nothing; and it refuses what it does not model rather than compare wrongly.
#include "plain_loop.h"

#include <gtest/gtest.h>

#include "lamina/core/error.h"
#include "support/sphere_model.h"

namespace lamina {
namespace {

sim::Simulation poked(const Model& m, const sim::Material& mat = {}) {
  sim::Simulation s = sim::make_simulation(m, mat, {});
  sim::fix_nodes(s, {0, 1, 2, 3, 4});
  const int32_t tip = m.node_count() / 2;
  s.f_ext.row(tip) << 150.0, -80.0, 40.0;  // mN, held
  s.f_ext.row(tip + 1) << -30.0, 20.0, 0.0;
  return s;
}

TEST(PlainLoop, StepsAsLaminaDoes) {
  const Model& m = test::sphere_links_model();
  sim::Simulation s = poked(m);
  cli::PlainLoop p = cli::make_plain_loop(s);
  double moved = 0.0, apart = 0.0;
  for (int k = 0; k < 300; ++k) {
    sim::step(s);
    cli::plain_step(p);
  }
  for (int32_t i = 0; i < m.node_count(); ++i)
    for (int d = 0; d < 3; ++d) {
      moved = std::max(moved, std::abs(s.x(i, d) - m.X(i, d)));
      apart = std::max(apart, std::abs(s.x(i, d) - p.x[3 * i + d]));
    }
  EXPECT_GT(moved, 1.0);  // the poke moved the tissue by millimetres
  // Lamina's explicit pass computes spring forces in single precision (docs/benchmarks.md): the
  // two agree to float's resolution of the motion, not to double's.
  EXPECT_LT(apart, 1e-6 * moved) << "the plain loop and sim::step disagree";
  for (int32_t i = 0; i < 5; ++i)
    for (int d = 0; d < 3; ++d) EXPECT_EQ(p.x[3 * i + d], m.X(i, d)) << "fixed node " << i;
}

TEST(PlainLoop, RefusesWhatItDoesNotModel) {
  const Model& m = test::sphere_links_model();
  sim::Material volume;
  volume.volume_stiffness_kpa = 10.0;
  EXPECT_THROW(cli::make_plain_loop(poked(m, volume)), Error);
  sim::Material anchored;
  anchored.anchor_stiffness_n_per_m = 1.0;
  EXPECT_THROW(cli::make_plain_loop(poked(m, anchored)), Error);
  sim::SolverOptions implicit;
  implicit.integrator = sim::Integrator::kImplicitEuler;
  EXPECT_THROW(cli::make_plain_loop(sim::make_simulation(m, {}, implicit)), Error);
}

}  // namespace
}  // namespace lamina
