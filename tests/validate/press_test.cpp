// The tool case of `lamina validate`: the sphere tool pressing the model through the contact code
// against finite elements pressed by the same sphere law.
#include <gtest/gtest.h>

#include "lamina/geometry/make_phantom.h"
#include "lamina/io/scene.h"
#include "lamina/model/build_model.h"
#include "lamina/validate/indentation.h"

namespace {

using namespace lamina;

// A small two-layer phantom (about 700 nodes) filled with tetrahedra, Neo-Hookean, with the
// physical liver's material as a scene resolves it (E = 6 kPa, nu = 0.45).
struct Pressed {
  Model model;
  sim::Material material;
  validate::FemMaterial fem_material;
  validate::Indentation indentation;
};

const Pressed& pressed() {
  static const Pressed p = [] {
    Pressed q;
    q.model = model::build_model(geometry::make_phantom({.spacing_mm = {3, 3, 3}}),
                                 {.skin_vertices = 400})
                  .model;
    io::Scene scene;
    scene.tet_model = sim::TetModel::kNeoHookean;
    io::prepare_scene(scene, q.model);
    q.material = scene.material;
    q.fem_material = {scene.elastic_material.young_modulus_kpa,
                      scene.elastic_material.poisson_ratio};
    q.indentation = validate::paper_indentation(q.model, 15.0);
    q.indentation.sphere_stiffness_kpa_per_mm = 10.0 * q.fem_material.young_modulus_kpa / 15.0;
    return q;
  }();
  return p;
}

// On the model's own tetrahedra and skin, the same sphere and the same tissue law: what is left
// is the time stepping to rest against Newton, so they agree closely; and both push into the
// organ, the deeper the harder.
TEST(PressSphere, TheModelThroughItsContactCodeMatchesFiniteElementsOnItsOwnTets) {
  const Pressed& p = pressed();
  const Model& m = p.model;
  const validate::TetMesh mesh{m.X, m.tets.T};
  const Eigen::MatrixX3d samples = m.X.topRows(m.layers[0].node_count);
  const sim::SolverOptions solver{.integrator = sim::Integrator::kImplicitEuler,
                                  .dt_s = 0.001,
                                  .rest_speed_mm_per_s = 0.01,
                                  .max_steps = 60000};
  double last = 0.0;
  for (double pct : {5.0, 10.0}) {
    SCOPED_TRACE(pct);
    const double depth = pct / 100.0 * p.indentation.organ_depth_mm;
    const validate::IndentResult ms =
        validate::press_mass_spring(m, p.material, solver, p.indentation, depth);
    const validate::IndentResult fem = validate::press_fem(
        mesh, p.fem_material, p.indentation, depth, validate::FemLaw::kNeoHookean, samples,
        {.load_steps = 10, .max_newton_iterations = 50, .tolerance = 1e-5});
    ASSERT_TRUE(ms.converged);
    ASSERT_TRUE(fem.converged);
    EXPECT_GT(fem.force_n, last);
    last = fem.force_n;
    EXPECT_NEAR(ms.force_n, fem.force_n, 0.05 * fem.force_n);
    const validate::FieldError e = validate::field_error(ms.skin_u, fem.skin_u);
    EXPECT_LT(e.rms_mm, 0.05 * e.reference_max_mm);
    // The sphere moved `depth` past its first touch; the skin under it follows, less the
    // penalty's own give.
    EXPECT_GT(e.reference_max_mm, 0.5 * depth);
  }
}

}  // namespace
