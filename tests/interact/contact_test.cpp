// Contact on the skin's surface: the nearest skin point, a force spread over the patch it
// touches, a sphere's penalty; each load sums to what the tool puts in (Newton's third law), and
// at rest under a held tool the tissue pushes back with exactly as much.
#include "lamina/interact/contact.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "lamina/core/error.h"
#include "lamina/geometry/winding_number.h"
#include "lamina/interact/haptic_proxy.h"
#include "support/held_sphere.h"
#include "support/sphere_model.h"

namespace {

using namespace lamina;

using test::front_node;
using test::held_sphere;
using test::sphere_model;

const interact::RoutingOptions kNoRouting{.routing = interact::Routing::kNone};

double longest_skin_edge(const Model& m) {
  double longest = 0.0;
  const Eigen::MatrixX3i& F = m.layers[0].F;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c)
      longest = std::max(longest, (m.X.row(F(f, c)) - m.X.row(F(f, (c + 1) % 3))).norm());
  return longest;
}

TEST(ClosestSkinPoint, LiesOnTheSkinNoFartherThanAnyNodeAndOnItsTriangle) {
  Eigen::Vector3d c;
  const Model& m = sphere_model(&c);
  for (const Eigen::Vector3d& dir :
       {Eigen::Vector3d(0, -1, 0), Eigen::Vector3d(1, 1, 1).normalized(),
        Eigen::Vector3d(-0.3, 0.2, 0.9).normalized()}) {
    const Eigen::Vector3d p = c + 60.0 * dir;  // outside the sphere
    const interact::SkinPoint at = interact::closest_skin_point(m, m.X, p);
    ASSERT_GE(at.face, 0);
    EXPECT_NEAR(at.barycentric.sum(), 1.0, 1e-12);
    EXPECT_GE(at.barycentric.minCoeff(), 0.0);
    Eigen::Vector3d q = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k)
      q += at.barycentric[k] * m.X.row(m.layers[0].F(at.face, k)).transpose();
    EXPECT_LT((q - at.point_mm).norm(), 1e-9);
    EXPECT_NEAR((p - at.point_mm).norm(), at.distance_mm, 1e-9);
    double nearest_node = 1e300;
    for (int32_t i = 0; i < m.layers[0].node_count; ++i)
      nearest_node = std::min(nearest_node, (m.X.row(i).transpose() - p).norm());
    EXPECT_LE(at.distance_mm, nearest_node + 1e-12);
    EXPECT_GT(at.distance_mm, nearest_node - longest_skin_edge(m));
  }
}

TEST(DepthUnderSkin, PositiveInsideNegativeOutsideAndTheDistanceToTheSkin) {
  // The winding number decides the side (1 inside the closed skin, 0 outside), the nearest skin
  // point the depth: along a line through the sphere's centre, depth falls linearly to zero at
  // the skin and goes negative beyond it.
  Eigen::Vector3d c;
  const Model& m = sphere_model(&c);
  const Eigen::Vector3d skin = m.X.row(front_node(m)).transpose();
  const Eigen::Vector3d out = (skin - c).normalized();
  const double radius = (skin - c).norm();
  EXPECT_NEAR(geometry::winding_number(m.X, m.layers[0].F, c), 1.0, 1e-9);
  EXPECT_NEAR(geometry::winding_number(m.X, m.layers[0].F, c + 3.0 * radius * out), 0.0, 1e-9);
  for (const double along : {0.5, 0.8, 0.95, 1.05, 1.3}) {
    const Eigen::Vector3d p = c + along * radius * out;
    const double depth = interact::depth_under_skin(m, m.X, p);
    EXPECT_EQ(depth > 0.0, along < 1.0) << along;
    EXPECT_NEAR(std::abs(depth), interact::closest_skin_point(m, m.X, p).distance_mm, 1e-12);
  }
  EXPECT_NEAR(interact::depth_under_skin(m, m.X, skin), 0.0, 1e-9);
}

TEST(SpreadOnPatch, SumsToTheForceOverMoreNodesAsThePatchWidensAndNeverOnTheFarSide) {
  Eigen::Vector3d c;
  const Model& m = sphere_model(&c);
  const int32_t node = front_node(m);
  const interact::SkinPoint at = interact::skin_point_at_node(m, m.X, node);
  const Eigen::Vector3d f(30.0, 400.0, -20.0);
  size_t last = 0;
  for (double radius : {0.0, 4.0, 8.0, 16.0}) {
    const interact::ForceRoute r = interact::spread_on_patch(m, m.X, at, f, radius);
    EXPECT_LT((interact::total_force(r) - f).norm(), 1e-9 * f.norm()) << "radius " << radius;
    EXPECT_GE(r.nodes.size(), last) << "radius " << radius;
    last = r.nodes.size();
    for (size_t k = 0; k < r.nodes.size(); ++k) {
      EXPECT_LT(r.nodes[k], m.layers[0].node_count) << "only skin nodes carry a pushing tool";
      // Within the patch, or a corner of a triangle that reaches into it.
      EXPECT_LT((m.X.row(r.nodes[k]) - m.X.row(node)).norm(), radius + longest_skin_edge(m));
      // Each node's share is along the force: a pressure, not a shear of its own.
      EXPECT_GT(r.forces.row(static_cast<Eigen::Index>(k)).dot(f), 0.0);
    }
  }
  EXPECT_EQ(interact::spread_on_patch(m, m.X, at, f, 0.0).nodes.size(), 1u)
      << "a point load on a node is that node's";
  EXPECT_GT(last, 10u);
  EXPECT_THROW(interact::skin_point_at_node(m, m.X, m.layers[0].node_count), Error);
}

TEST(SphereContact, PassesEachPressedPiecesForceToItsTrianglesCornersAndIsContinuous) {
  Eigen::Vector3d c;
  const Model& m = sphere_model(&c);
  const int32_t node = front_node(m);
  interact::PressingSphere sphere{.radius_mm = 8.0, .stiffness_kpa_per_mm = 2.0};
  // Outside, not touching: nothing.
  sphere.center_mm = m.X.row(node).transpose() - Eigen::Vector3d(0, 9.0, 0);
  EXPECT_TRUE(interact::sphere_contact(m, m.X, sphere).nodes.empty());
  // 3 mm into the pole.
  sphere.center_mm = m.X.row(node).transpose() - Eigen::Vector3d(0, 5.0, 0);
  const interact::ForceRoute r = interact::sphere_contact(m, m.X, sphere);
  std::vector<interact::PressedPiece> pieces;
  interact::press_sphere(m.X, m.X, m.layers[0].F, sphere, pieces);
  const Eigen::Vector3d total = interact::total_force(r);
  EXPECT_LT((total - interact::pressed_total(pieces)).norm(), 1e-9 * total.norm())
      << "the nodes carry exactly what the pieces were pressed with";
  EXPECT_GT(total.y() / total.norm(), std::cos(10.0 * M_PI / 180.0)) << "pushed inward (+y)";
  EXPECT_GT(r.nodes.size(), 3u) << "an 8 mm sphere 3 mm deep covers more than one triangle";
  for (int32_t i : r.nodes) EXPECT_LT(i, m.layers[0].node_count);
  EXPECT_GE(r.contact_node, 0);
  // Continuous: a 1 um move changes the push by about its stiffness x 1 um, not by a jump.
  interact::PressingSphere moved = sphere;
  moved.center_mm.y() += 1e-3;
  const Eigen::Vector3d total2 = interact::total_force(interact::sphere_contact(m, m.X, moved));
  EXPECT_GT(total2.y(), total.y()) << "deeper pushes harder";
  EXPECT_LT((total2 - total).norm(), 1e-2 * total.norm());
}

// At rest under a held tool the tissue's push on the loaded nodes is minus the load, and the
// load is minus the force on the tool (Newton's third law) within 1%.
TEST(Contact, AtRestTheTissuePushesBackWithExactlyTheToolsLoad) {
  Eigen::Vector3d c;
  const Model& m = sphere_model(&c);
  // At rest means slow enough that damping (8 kg/s x speed) is far below 1% of the load. The
  // rest implicit Euler reaches does not depend on dt: 50 ms steps get there in a quarter of
  // the 10 ms ones' time (56 s under ASan at 10 ms).
  sim::Simulation s = held_sphere(
      {.integrator = sim::Integrator::kImplicitEuler, .dt_s = 0.05, .rest_speed_mm_per_s = 1e-4});

  const int32_t node = front_node(m);
  const interact::ToolTip tip{.active = true,
                              .center_mm = m.X.row(node).transpose() - Eigen::Vector3d(0, 5.0, 0),
                              .radius_mm = 8.0,
                              .stiffness_n_per_m = 20.0};
  interact::Loads loads;
  interact::ForceRoute load;
  interact::HapticProxy proxy;
  int quiet = 0;  // steps in a row below the rest speed
  bool rested = false;
  for (int k = 0; k < 50000 && !rested; ++k) {
    interact::clear_loads(s, loads);
    load = interact::load_of_tip(m, s.x, tip, kNoRouting, proxy);
    interact::add_load(s, load, loads);
    quiet = sim::step(s).converged ? quiet + 1 : 0;
    rested = quiet >= 100;
  }
  ASSERT_TRUE(rested);
  ASSERT_FALSE(load.nodes.empty()) << "the tip still touches at rest";
  const Eigen::Vector3d on_tissue = interact::total_force(load);
  const Eigen::Vector3d push_back = interact::reaction_force(s, loads);
  EXPECT_LT((push_back + on_tissue).norm(), 0.01 * on_tissue.norm())
      << "tissue " << push_back.transpose() << " vs load " << on_tissue.transpose();
  // The dent at rest is 0.50 mm (0.4995 mm with one thread at -O1: round-off in where the rest
  // is declared), a clear dent against the 3 mm the sphere would overlap the rest shape.
  EXPECT_GT(s.x(node, 1) - m.X(node, 1), 0.4) << "the skin gave way";
}

}  // namespace
