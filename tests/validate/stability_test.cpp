#include "lamina/validate/stability.h"

#include <gtest/gtest.h>

#include "lamina/geometry/make_phantom.h"
#include "lamina/io/scene.h"
#include "lamina/model/build_model.h"
#include "lamina/model/identify_springs.h"

namespace {

using namespace lamina;

// A small two-layer phantom (about 600 nodes) with E = 6 kPa, nu = 0.45 springs, lumped masses,
// the volume term and critical damping of its slowest mode, as a physical scene resolves it.
struct Physical {
  Model model;
  sim::Material material;
  validate::Indentation indentation;
};

const Physical& physical() {
  static const Physical p = [] {
    Physical q;
    q.model = model::build_model(geometry::make_phantom({.spacing_mm = {3, 3, 3}}),
                                 {.skin_vertices = 400})
                  .model;
    const model::SpringIdentification id = model::identify_springs(
        q.model, {.young_modulus_kpa = 6.0, .poisson_ratio = 0.45},
        q.model.springs.stiffness_n_per_m);
    q.material = {.stiffness_n_per_m = 0.0, .damping_kg_per_s = 0.0, .node_mass_kg = 0.0,
                  .volume_stiffness_kpa = id.volume_stiffness_kpa};
    q.indentation = validate::paper_indentation(q.model, 15.0);
    sim::Simulation s = sim::make_simulation(q.model, q.material);
    sim::fix_nodes(s, sim::nodes_near_plane(q.model, q.indentation.held_point_mm,
                                            q.indentation.held_normal,
                                            q.indentation.held_distance_mm));
    q.material.mass_damping_per_s = 2.0 * sim::lowest_angular_frequency(s);
    return q;
  }();
  return p;
}

validate::StabilityResult run(const validate::StabilityCase& c) {
  const Physical& p = physical();
  return validate::run_stability_case(p.model, p.material, {}, p.indentation, c);
}

void expect_passed(const validate::StabilityResult& r) {
  const validate::StabilityOptions o;
  SCOPED_TRACE(r.c.name + ", " + io::integrator_name(r.c.integrator));
  EXPECT_TRUE(r.finite);
  EXPECT_EQ(r.order.outside_nodes, 0);
  EXPECT_FALSE(r.order.surfaces_cross);
  EXPECT_GT(r.order_checks, 5);
  EXPECT_TRUE(r.loaded_at_rest);
  EXPECT_TRUE(r.returned_at_rest);
  EXPECT_GT(r.release_energy_j, 0.0);
  EXPECT_LE(r.max_energy_j, r.release_energy_j * (1.0 + o.energy_rise_tolerance));
  EXPECT_LE(r.final_energy_j, r.release_energy_j * o.final_energy_fraction);
  EXPECT_LE(r.rest_error_mm, o.rest_tolerance_mm);
  EXPECT_TRUE(r.passed(o));
}

TEST(LayerOrder, RestIsOrderedAndAnInnerNodePushedOutIsCaught) {
  const Model& m = physical().model;
  EXPECT_TRUE(validate::check_layer_order(m, m.X).ordered());
  // Carry one inner node 40 mm past the skin's front, straight out.
  Eigen::MatrixX3d x = m.X;
  const int32_t inner = m.layers[1].first_node;
  int32_t front = inner;
  for (int32_t i = inner; i < inner + m.layers[1].node_count; ++i)
    if (m.X(i, 1) < m.X(front, 1)) front = i;
  x(front, 1) = m.X.col(1).minCoeff() - 40.0;
  const validate::LayerOrder o = validate::check_layer_order(m, x);
  EXPECT_EQ(o.outside_nodes, 1);
  EXPECT_TRUE(o.surfaces_cross);
}

TEST(Stability, DeepIndentationPullAndThreeToolsReleaseBackToRest) {
  using validate::LoadKind;
  expect_passed(run({"indent 40%", LoadKind::kIndent, 0.4}));
  expect_passed(run({"pull 30%", LoadKind::kPull, 0.3}));
  // 0.5 N each: 12 mm. At 1 N each this coarse model snaps through (256 mm) into an inverted
  // equilibrium that the springs hold after the release (docs/validation.md, "Stability").
  const validate::StabilityResult tools = run({"3 tools 0.5 N", LoadKind::kTools, 0.0, 3, 0.5});
  expect_passed(tools);
  EXPECT_GT(tools.peak_displacement_mm, 5.0);  // a real load, not a touch
}

TEST(Stability, ImplicitIntegratorsAtTenTimesThePapersDt) {
  for (auto in : {sim::Integrator::kImplicitEuler, sim::Integrator::kProjective}) {
    const validate::StabilityResult r =
        run({"indent 30%", validate::LoadKind::kIndent, 0.3, 0, 0.0, in, 0.1});
    expect_passed(r);
    EXPECT_EQ(r.recoveries, 0);
  }
}

}  // namespace
