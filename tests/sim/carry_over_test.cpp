// A simulation carried over to its model cut (issue 47): the cut organ at rest stays at rest,
// its pieces pulled apart separate along the cut and come back to rest, and the state, the
// loads and the mass carry over with their totals kept.
#include "lamina/sim/carry_over.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "lamina/core/error.h"
#include "lamina/model/cut_tetrahedra.h"
#include "lamina/sim/simulation.h"
#include "support/tet_phantom.h"

namespace {

using namespace lamina;

sim::Material physical() {
  return {.stiffness_n_per_m = 0.0,
          .damping_kg_per_s = 0.0,
          .mass_damping_per_s = 5.0,
          .node_mass_kg = 0.0,
          .young_modulus_kpa = 6.0};
}

struct CutOrgan {
  Model model;
  std::vector<int32_t> origin;
  model::CutReport report;
  double x0 = 0.0;
};

// The small phantom cut in two by the plane x = x0 through its middle.
const CutOrgan& cut_organ() {
  static const CutOrgan c = [] {
    CutOrgan o;
    const Model& m = test::tet_phantom();
    o.x0 = m.X.col(0).mean() + 0.31;
    const Eigen::Vector3d lo = m.X.colwise().minCoeff(), hi = m.X.colwise().maxCoeff();
    const model::Blade b = model::sweep_blade({Eigen::Vector3d(o.x0, lo.y() - 5, lo.z() - 5),
                                               Eigen::Vector3d(o.x0, hi.y() + 5, lo.z() - 5)},
                                              Eigen::Vector3d::UnitZ(), hi.z() - lo.z() + 10);
    model::cut_tetrahedra(m, m.X, b, o.model, o.origin, o.report);
    return o;
  }();
  return c;
}

sim::Simulation held_uncut(const sim::SolverOptions& o = {
                               .integrator = sim::Integrator::kImplicitEuler}) {
  sim::Simulation s = sim::make_simulation(test::tet_phantom(), physical(), o);
  sim::fix_nodes(s, test::posterior_nodes(test::tet_phantom()));
  return s;
}

// The largest distance between two copies of one node.
double widest_gap(const sim::Simulation& s, const std::vector<int32_t>& origin) {
  double gap = 0.0;
  for (size_t i = 1; i < origin.size(); ++i)
    for (size_t j = i; j-- > 0 && origin[j] == origin[i];)
      gap = std::max(
          gap,
          (s.x.row(static_cast<Eigen::Index>(i)) - s.x.row(static_cast<Eigen::Index>(j))).norm());
  return gap;
}

TEST(CarryOver, ACutOrganAtRestStaysAtRest) {
  const CutOrgan& c = cut_organ();
  ASSERT_EQ(c.report.pieces.size(), 2u);
  sim::Simulation s = sim::carry_over(held_uncut(), c.model, c.origin);
  for (int k = 0; k < 20; ++k) ASSERT_EQ(sim::step(s).unstable, sim::Instability::kNone);
  EXPECT_LT((s.x - c.model.X).cwiseAbs().maxCoeff(), 1e-6);
}

TEST(CarryOver, TheStateTheLoadsAndTheMassCarryOverWithTheirTotalsKept) {
  const CutOrgan& c = cut_organ();
  sim::Simulation before = held_uncut();
  // A push in the middle of the front, for a few steps: a deformed, moving state.
  for (int32_t i = 0; i < before.model().surface_node_count(); ++i)
    if (std::abs(before.model().X(i, 0) - c.x0) < 20.0) before.f_ext(i, 1) = 30.0;
  for (int k = 0; k < 5; ++k) sim::step(before);
  const sim::Simulation after = sim::carry_over(before, c.model, c.origin);
  ASSERT_EQ(after.model().node_count(), c.model.node_count());
  EXPECT_EQ(after.time_s, before.time_s);
  EXPECT_EQ(after.steps, before.steps);
  for (int32_t i = 0; i < c.model.node_count(); ++i) {
    ASSERT_EQ(after.x.row(i), before.x.row(c.origin[i]));
    ASSERT_EQ(after.v.row(i), before.v.row(c.origin[i]));
    ASSERT_EQ(after.fixed()[i], before.fixed()[c.origin[i]]);
  }
  const Eigen::Vector3d f0 = before.f_ext.colwise().sum(), f1 = after.f_ext.colwise().sum();
  EXPECT_LT((f1 - f0).norm(), 1e-9 * f0.norm());
  double m0 = 0.0, m1 = 0.0;
  for (double m : before.mass_kg()) m0 += m;
  for (double m : after.mass_kg()) m1 += m;
  EXPECT_NEAR(m1, m0, 1e-9 * m0);
}

TEST(CarryOver, PiecesPulledApartOpenTheCutAndComeBackToRest) {
  const CutOrgan& c = cut_organ();
  sim::Simulation s = sim::carry_over(held_uncut(), c.model, c.origin);
  // Each side pulled away from the cut near it, the way a surgeon spreads a wound.
  int loaded = 0;
  for (int32_t i = 0; i < c.model.surface_node_count(); ++i) {
    const double d = c.model.X(i, 0) - c.x0;
    if (std::abs(d) < 15.0) s.f_ext(i, 0) = d < 0 ? -20.0 : 20.0, ++loaded;
  }
  ASSERT_GT(loaded, 4);
  for (int k = 0; k < 50; ++k) ASSERT_EQ(sim::step(s).unstable, sim::Instability::kNone) << k;
  const double open = widest_gap(s, c.origin);
  EXPECT_GT(open, 1.0) << "the cut did not open";
  EXPECT_EQ(sim::inverted_tets(c.model, s.x), 0);
  s.f_ext.setZero();
  sim::RestStreak rest{.needed = sim::quiet_steps(s)};
  bool at_rest = false;
  for (int k = 0; k < 5000 && !at_rest; ++k) {
    const sim::StepStats st = sim::step(s);
    ASSERT_EQ(st.unstable, sim::Instability::kNone) << "released, step " << k;
    at_rest = rest.update(st);
  }
  ASSERT_TRUE(at_rest);
  std::printf("cut opened %.2f mm; back at rest within %.3f mm of the rest shape\n", open,
              (s.x - c.model.X).rowwise().norm().maxCoeff());
  EXPECT_LT((s.x - c.model.X).rowwise().norm().maxCoeff(), 0.5);
  EXPECT_LT(widest_gap(s, c.origin), 0.5);
}

TEST(CarryOver, AnOriginThatDoesNotMatchIsRefused) {
  const CutOrgan& c = cut_organ();
  std::vector<int32_t> short_origin(c.origin.begin(), c.origin.end() - 1);
  EXPECT_THROW(sim::carry_over(held_uncut(), c.model, short_origin), Error);
  std::vector<int32_t> bad = c.origin;
  bad[0] = 1 << 30;
  EXPECT_THROW(sim::carry_over(held_uncut(), c.model, bad), Error);
}

}  // namespace
