// A simulation carried over to its model cut (issue 47): the cut organ at rest stays at rest,
// its pieces pulled apart separate along the cut and come back to rest, and the state, the
// loads and the mass carry over with their totals kept.
#include "lamina/sim/carry_over.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "lamina/core/error.h"
#include "lamina/model/cut_tetrahedra.h"
#include "lamina/model/identify_tets.h"
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

// The carried simulation takes the constants of the tetrahedra the cut left as they were from
// the one it continues (model::same_tets()) instead of identifying them again: they must be
// exactly a fresh identification's, after a first cut and after a second one across the copies
// of the first (whose copies are then found as themselves, not as the tetrahedron they came
// from).
TEST(CarryOver, TheTetrahedraTheCutLeftKeepTheirConstantsExactly) {
  const CutOrgan& c = cut_organ();
  const Model& m = c.model;
  const Eigen::Vector3d lo = m.X.colwise().minCoeff(), hi = m.X.colwise().maxCoeff();
  const double y0 = m.X.col(1).mean() + 0.17;
  const model::Blade across = model::sweep_blade(
      {Eigen::Vector3d(lo.x() - 5, y0, lo.z() - 5), Eigen::Vector3d(hi.x() + 5, y0, lo.z() - 5)},
      Eigen::Vector3d::UnitZ(), hi.z() - lo.z() + 10);
  Model twice;
  std::vector<int32_t> origin2;
  model::CutReport report2;
  model::cut_tetrahedra(m, m.X, across, twice, origin2, report2);
  ASSERT_GT(report2.cut_tets, 0);

  const sim::Simulation once = sim::carry_over(held_uncut(), m, c.origin);
  const sim::Simulation again = sim::carry_over(once, twice, origin2);
  const model::ElasticMaterial e{.young_modulus_kpa = 6.0, .poisson_ratio = 0.45};
  struct Case {
    const Model* cut;
    const sim::Simulation* sim;
    const Model* before;
    const std::vector<int32_t>* origin;
    int64_t divided;
  };
  for (const auto& [cut, sim, before, origin, divided] :
       {Case{&m, &once, &test::tet_phantom(), &c.origin, c.report.cut_tets},
        Case{&twice, &again, &m, &origin2, report2.cut_tets}}) {
    const model::TetIdentification fresh = model::identify_tets(*cut, e);
    const model::TetIdentification& carried = sim->tet_identification();
    ASSERT_EQ(carried.q_n_per_m.rows(), fresh.q_n_per_m.rows());
    EXPECT_EQ(carried.q_n_per_m, fresh.q_n_per_m);
    EXPECT_EQ(carried.tet_springs, fresh.tet_springs);
    EXPECT_EQ(carried.spring_n_per_m, fresh.spring_n_per_m);
    EXPECT_EQ(carried.rest_volume_mm3, fresh.rest_volume_mm3);
    // Every tetrahedron but the divided ones' copies is found, each as the same element.
    const std::vector<int32_t> same = model::same_tets(*before, *cut, *origin);
    int64_t found = 0;
    for (size_t t = 0; t < same.size(); ++t) {
      if (same[t] < 0) continue;
      ++found;
      for (int k = 0; k < 4; ++k)
        ASSERT_EQ((*origin)[static_cast<size_t>(cut->tets.T(static_cast<Eigen::Index>(t), k))],
                  before->tets.T(same[t], k));
      ASSERT_EQ(cut->tets.share_of(static_cast<int64_t>(t)), before->tets.share_of(same[t]));
    }
    EXPECT_EQ(found, before->tets.size() - divided);
    // Each spring found once is the one between copies of its ends; the springs not found are
    // those at copied nodes (or gone with no successor).
    const std::vector<int32_t> springs = model::same_springs(*before, *cut, *origin);
    ASSERT_EQ(springs.size(), before->springs.size());
    std::vector<int32_t> copies(static_cast<size_t>(before->node_count()), 0);
    for (const int32_t o : *origin) ++copies[static_cast<size_t>(o)];
    int64_t mapped = 0;
    for (size_t e = 0; e < springs.size(); ++e) {
      const int32_t f = springs[e];
      if (f < 0) {
        EXPECT_TRUE(copies[before->springs.i[e]] > 1 || copies[before->springs.j[e]] > 1) << e;
        continue;
      }
      ++mapped;
      ASSERT_EQ((*origin)[static_cast<size_t>(cut->springs.i[f])], before->springs.i[e]);
      ASSERT_EQ((*origin)[static_cast<size_t>(cut->springs.j[f])], before->springs.j[e]);
    }
    EXPECT_GT(mapped, static_cast<int64_t>(before->springs.size()) * 9 / 10);
  }
}

// The earlier identification's tables must fit: refused, naming the problem, otherwise.
TEST(CarryOver, KnownTablesThatDoNotFitTheModelAreRefused) {
  const CutOrgan& c = cut_organ();
  const model::ElasticMaterial e{.young_modulus_kpa = 6.0, .poisson_ratio = 0.45};
  const model::TetIdentification before = model::identify_tets(test::tet_phantom(), e);
  model::KnownTets known{.before = &before,
                         .tets = model::same_tets(test::tet_phantom(), c.model, c.origin),
                         .springs = model::same_springs(test::tet_phantom(), c.model, c.origin)};
  EXPECT_EQ(model::identify_tets(c.model, e, model::TetElasticity::kCoupled, known).q_n_per_m,
            model::identify_tets(c.model, e).q_n_per_m);
  model::KnownTets short_tets = known;
  short_tets.tets.pop_back();
  EXPECT_THROW(model::identify_tets(c.model, e, model::TetElasticity::kCoupled, short_tets), Error);
  model::KnownTets far_tet = known;
  far_tet.tets[0] = static_cast<int32_t>(before.q_n_per_m.rows());
  EXPECT_THROW(model::identify_tets(c.model, e, model::TetElasticity::kCoupled, far_tet), Error);
  model::KnownTets far_spring = known;
  far_spring.springs[0] = static_cast<int32_t>(c.model.springs.size());
  EXPECT_THROW(model::identify_tets(c.model, e, model::TetElasticity::kCoupled, far_spring), Error);
  // A spring named wrongly is not trusted: each is checked against the tetrahedron's corners.
  model::KnownTets wrong_spring = known;
  for (int32_t& f : wrong_spring.springs) f = f >= 0 ? (f + 1) % c.model.springs.size() : f;
  EXPECT_EQ(
      model::identify_tets(c.model, e, model::TetElasticity::kCoupled, wrong_spring).tet_springs,
      model::identify_tets(c.model, e).tet_springs);
}

// A cut model whose tetrahedra are not in the cut's order (two swapped) loses the walk there:
// those are identified afresh, none is taken for another.
TEST(CarryOver, TetrahedraOutOfTheCutsOrderAreNeverTakenForOthers) {
  const CutOrgan& c = cut_organ();
  Model shuffled = c.model;
  const Eigen::Index last = shuffled.tets.size() - 1;
  shuffled.tets.T.row(3).swap(shuffled.tets.T.row(last));
  if (!shuffled.tets.share.empty()) std::swap(shuffled.tets.share[3], shuffled.tets.share[last]);
  if (!shuffled.tets.material.empty())
    std::swap(shuffled.tets.material[3], shuffled.tets.material[last]);
  std::swap(shuffled.tets.region[3], shuffled.tets.region[last]);
  const std::vector<int32_t> same = model::same_tets(test::tet_phantom(), shuffled, c.origin);
  int64_t found = 0;
  for (size_t t = 0; t < same.size(); ++t) {
    if (same[t] < 0) continue;
    ++found;
    for (int k = 0; k < 4; ++k)
      ASSERT_EQ(c.origin[static_cast<size_t>(shuffled.tets.T(static_cast<Eigen::Index>(t), k))],
                test::tet_phantom().tets.T(same[t], k));
  }
  EXPECT_GT(found, 0);
  EXPECT_LT(found, test::tet_phantom().tets.size() - c.report.cut_tets);
  const sim::Simulation s = sim::carry_over(held_uncut(), shuffled, c.origin);
  EXPECT_EQ(
      s.tet_identification().q_n_per_m,
      model::identify_tets(shuffled, {.young_modulus_kpa = 6.0, .poisson_ratio = 0.45}).q_n_per_m);
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
