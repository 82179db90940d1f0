// Implicit Euler's step shortened where it would collapse a tetrahedron (inversion_limit.cpp):
// a load the linearisation at the step's start cannot follow inverts nothing, and ordinary
// motion is taken whole.
#include <gtest/gtest.h>

#include "lamina/sim/simulation.h"
#include "support/tet_phantom.h"

namespace lamina {
namespace {

TEST(InversionLimit, AStepTheLinearisationCannotFollowIsShortenedAndInvertsNoTetrahedron) {
  const Model& m = test::tet_phantom();
  sim::Simulation s = sim::make_simulation(
      m, test::kTetLiver, {.integrator = sim::Integrator::kImplicitEuler, .dt_s = 0.01});
  sim::fix_nodes(s, test::posterior_nodes(m));
  // 3 N on the most anterior skin node, along +y into the organ: one 10 ms step of the system
  // linearised at rest moves that node tens of millimetres, through its own tetrahedra.
  int32_t front = 0;
  for (int32_t i = 1; i < m.layers[0].node_count; ++i)
    if (m.X(i, 1) < m.X(front, 1)) front = i;
  s.f_ext.row(front) << 0.0, 3000.0, 0.0;
  int shortened = 0;
  for (int k = 0; k < 30; ++k) {
    const sim::StepStats st = sim::step(s);
    ASSERT_EQ(st.unstable, sim::Instability::kNone) << "step " << k;
    EXPECT_GT(st.step_fraction, 0.0);
    EXPECT_LE(st.step_fraction, 1.0);
    shortened += st.step_fraction < 1.0 ? 1 : 0;
    EXPECT_EQ(sim::inverted_tets(m, s.x), 0) << "step " << k;
  }
  EXPECT_GT(shortened, 0) << "the load was meant to be more than one step can follow";
  EXPECT_GT((s.x - m.X).rowwise().norm().maxCoeff(), 5.0) << "the load still moves the organ";

  // The shared 300 mN poke: every step whole, as before the limit.
  sim::Simulation p = test::poked_tet_phantom({.integrator = sim::Integrator::kImplicitEuler});
  for (int k = 0; k < 20; ++k) EXPECT_EQ(sim::step(p).step_fraction, 1.0) << "step " << k;
}

}  // namespace
}  // namespace lamina
