// The tetrahedra's stiffness assembled into 3x3 node blocks (src/sim/tet_assembly.cpp,
// assemble_tets in tet_term.cpp): the same product as the element-by-element one, a symmetric
// matrix, and implicit Euler with it steps as it does without.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>

#include "lamina/model/cut_tetrahedra.h"
#include "lamina/sim/simulation.h"
#include "sim/block_rows.h"
#include "sim/force_terms.h"
#include "sim/solver.h"  // white box: both products side by side
#include "support/random_rows.h"
#include "support/tet_phantom.h"

namespace {

using namespace lamina;

// The small phantom cut through by a plane: copies of divided tetrahedra, nodes copied on both
// sides, whose rows the pattern takes from the cut model's springs.
const Model& cut_phantom() {
  static const Model cut = [] {
    const Model& m = test::tet_phantom();
    const Eigen::Vector3d lo = m.X.colwise().minCoeff(), hi = m.X.colwise().maxCoeff();
    const double x0 = m.X.col(0).mean() + 0.31;
    const model::Blade b = model::sweep_blade(
        {Eigen::Vector3d(x0, lo.y() - 5, lo.z() - 5), Eigen::Vector3d(x0, hi.y() + 5, lo.z() - 5)},
        Eigen::Vector3d::UnitZ(), hi.z() - lo.z() + 10);
    Model out;
    std::vector<int32_t> origin;
    model::CutReport report;
    model::cut_tetrahedra(m, m.X, b, out, origin, report);
    return out;
  }();
  return cut;
}

void expect_assembled_equals_element_product(const Model& m) {
  ASSERT_TRUE(m.has_tets());
  sim::Simulation sim =
      sim::make_simulation(m, test::kTetLiver, {.integrator = sim::Integrator::kImplicitEuler});
  sim::detail::Solver& s = sim.solver();
  // Jiggled by up to 2 mm: edges stretched and compressed (the clamped geometric term at work).
  const Eigen::MatrixX3d x = test::jiggle(m.X, 2.0, 3);
  const Eigen::MatrixX3d p = test::random_rows(m.node_count(), 1.0, 7);
  sim::detail::tet_pass(s, x, /*linearise=*/true, 1, &p);
  sim::detail::setup_tet_assembly(s);
  sim::detail::assemble_tets(s, 1);
  // The steps' product: p packed by node (a 0 in the fourth lane: the next row's float it meets
  // must add nothing).
  std::vector<double>& packed = s.tets.assembly.packed;
  ASSERT_EQ(packed.size(), 4u * static_cast<size_t>(m.node_count()));
  for (int32_t i = 0; i < m.node_count(); ++i)
    for (int c = 0; c < 4; ++c) packed[4 * i + c] = c < 3 ? p(i, c) : 0.0;
  double largest = 0.0, worst = 0.0;
  for (int32_t i = 0; i < m.node_count(); ++i) {
    double element[3] = {0, 0, 0}, assembled[3] = {0, 0, 0};
    sim::detail::gather_tets(s, s.tets.product, i, element[0], element[1], element[2]);
    sim::detail::assembled_tet_product_packed(s.tets.assembly, i, packed.data(), assembled);
    for (int c = 0; c < 3; ++c) {
      largest = std::max(largest, std::abs(element[c]));
      worst = std::max(worst, std::abs(assembled[c] - element[c]));
    }
  }
  ASSERT_GT(largest, 1.0);
  // Both keep the linearisation in float and sum it in another order: about 1e-7 of the terms.
  EXPECT_LT(worst, 1e-5 * largest);

  // K is symmetric: block (i, j) is block (j, i) transposed.
  const sim::detail::TetAssembly& a = s.tets.assembly;
  double largest_block = 0.0, asymmetry = 0.0;
  for (int32_t i = 0; i < m.node_count(); ++i)
    for (int32_t e = a.offsets[i]; e < a.offsets[i + 1]; ++e) {
      const int32_t j = a.column[e];
      const auto first = a.column.begin() + a.offsets[j],
                 last = a.column.begin() + a.offsets[j + 1];
      const auto at = std::find(first, last, i);
      ASSERT_NE(at, last) << "node " << j << " lacks its neighbour " << i;
      const float* b = a.block.data() + 9 * e;
      const float* t = a.block.data() + 9 * (at - a.column.begin());
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
          largest_block = std::max(largest_block, std::abs(double{b[3 * r + c]}));
          asymmetry = std::max(asymmetry, std::abs(double{b[3 * r + c]} - t[3 * c + r]));
        }
    }
  ASSERT_GT(largest_block, 0.0);
  EXPECT_LT(asymmetry, 1e-5 * largest_block);

  // Two threads, each adding to its own rows, sum every block in the same order as one.
  const std::vector<float> one = a.block;
  sim::detail::assemble_tets(s, 2);
  EXPECT_EQ(a.block, one);
}

TEST(TetAssembly, EqualsTheElementByElementProductAndIsSymmetric) {
  expect_assembled_equals_element_product(test::tet_phantom());
}

TEST(TetAssembly, EqualsTheElementByElementProductOnACutModel) {
  ASSERT_GT(cut_phantom().node_count(), test::tet_phantom().node_count());
  expect_assembled_equals_element_product(cut_phantom());
}

TEST(TetAssembly, ImplicitEulerStepsAsWithTheElementProduct) {
  // The default scene's kind of poke on a small liver, 150 steps at 10 ms (several CG
  // iterations a step): the assembled matrix and the element product reach the same states.
  const Model& m = test::tet_phantom();
  auto run = [&](bool assembled, int32_t& iterations) -> Eigen::MatrixX3d {
    sim::Simulation sim =
        test::poked_tet_phantom({.integrator = sim::Integrator::kImplicitEuler, .dt_s = 0.01});
    sim::detail::TetAssembly& a = sim.solver().tets.assembly;
    EXPECT_FALSE(a.on) << "a model this small keeps the element product";
    if (assembled) sim::detail::setup_tet_assembly(sim.solver());  // every product by blocks
    iterations = test::step_counting_iterations(sim, 150);
    return Eigen::MatrixX3d(sim.x);
  };
  int32_t element_iterations = 0, assembled_iterations = 0;
  const Eigen::MatrixX3d element = run(false, element_iterations);
  const Eigen::MatrixX3d assembled = run(true, assembled_iterations);
  const double motion = (element - m.X).rowwise().norm().maxCoeff();
  ASSERT_GT(motion, 1.0);
  EXPECT_LT((assembled - element).rowwise().norm().maxCoeff(), 1e-4 * motion);
  EXPECT_GT(element_iterations, 150);
  EXPECT_NEAR(assembled_iterations, element_iterations, 0.02 * element_iterations);
}

// The stiffness at rest written through the assembly's table (CoupledTets::add_rest_stiffness:
// each block found once, the rows summed on the threads) is the one written block by block with
// a search per corner pair, exactly: the same sums in the same order, held nodes left out.
void expect_rest_stiffness_through_the_table_is_the_searched_one(const Model& m,
                                                                 sim::TetModel energy) {
  sim::Material material = test::kTetLiver;
  material.tet_model = energy;
  sim::Simulation sim =
      sim::make_simulation(m, material, {.integrator = sim::Integrator::kImplicitEuler});
  sim::detail::Solver& s = sim.solver();
  ASSERT_FALSE(s.tets.assembly.on) << "a model this small has no table unless asked";
  // Every fifth node held (no row), as an indenter or a clamp leaves them.
  std::vector<int32_t> row_of(static_cast<size_t>(m.node_count()), -1);
  int32_t rows = 0;
  for (int32_t i = 0; i < m.node_count(); ++i)
    if (i % 5 != 2) row_of[static_cast<size_t>(i)] = rows++;
  sim::detail::BlockRows searched, tabled;
  sim::detail::rest_stiffness_blocks(s, row_of, rows, searched);
  sim::detail::setup_tet_assembly(s);
  const int threads = omp_get_max_threads();
  for (int t : {1, 2}) {
    omp_set_num_threads(t);
    sim::detail::rest_stiffness_blocks(s, row_of, rows, tabled);
    EXPECT_EQ(tabled.column, searched.column);
    EXPECT_EQ(tabled.value, searched.value) << t << " thread(s)";
  }
  omp_set_num_threads(threads);
  ASSERT_GT(*std::max_element(searched.value.begin(), searched.value.end()), 0.0);
}

TEST(TetAssembly, TheStiffnessAtRestThroughItsTableIsTheSearchedOne) {
  for (const sim::TetModel energy : {sim::TetModel::kSprings, sim::TetModel::kNeoHookean}) {
    SCOPED_TRACE(energy == sim::TetModel::kSprings ? "coupled springs" : "Neo-Hookean");
    expect_rest_stiffness_through_the_table_is_the_searched_one(test::tet_phantom(), energy);
    expect_rest_stiffness_through_the_table_is_the_searched_one(cut_phantom(), energy);
  }
}

}  // namespace
