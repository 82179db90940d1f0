#include "lamina/interact/tools.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>

#include "lamina/core/error.h"
#include "lamina/geometry/make_phantom.h"
#include "lamina/model/build_model.h"
#include "support/sphere_model.h"

namespace {

using namespace lamina;

using test::sphere_model;

std::set<int32_t> ring_members(const Model& m, int32_t node, int32_t rings) {
  std::set<int32_t> s;
  for (int32_t r = 0; r < rings; ++r)
    for (int64_t k = 0; k < m.rings.ring_size(node, r); ++k) s.insert(m.rings.ring(node, r)[k]);
  return s;
}

TEST(ForceLine, ThroughTheCentreOfASphereCrossesTwoSurfacesPerLayer) {
  Eigen::Vector3d c;
  const Model& m = sphere_model(&c);
  ASSERT_EQ(m.layer_count(), 2);
  const int32_t contact = 10;
  const Eigen::Vector3d inward = c - m.X.row(contact).transpose();
  const auto crossings = interact::force_line_crossings(m, m.X, contact, inward);
  ASSERT_EQ(crossings.size(), 4u);  // 2S: skin (contact), inner in, inner out, far skin
  const int layers[4] = {0, 1, 1, 0};
  for (int k = 0; k < 4; ++k) EXPECT_EQ(crossings[k].layer, layers[k]) << k;
  EXPECT_NEAR(crossings[1].distance_mm, 8.0, 1.5);   // the inner layer is 8 mm deep
  EXPECT_NEAR(crossings[3].distance_mm, 40.0, 1.5);  // the far side, a diameter away
  // Outward, the line leaves at once: only the contact.
  EXPECT_EQ(interact::force_line_crossings(m, m.X, contact, -inward).size(), 1u);
}

TEST(RouteForce, ExactlyTheFirstPCrossingsReceiveForce) {
  Eigen::Vector3d c;
  const Model& m = sphere_model(&c);
  const int32_t contact = 10;
  const Eigen::Vector3d force = 50.0 * (c - m.X.row(contact).transpose()).normalized();
  for (int32_t p = 1; p <= 4; ++p) {
    SCOPED_TRACE("P = " + std::to_string(p));
    const interact::ForceRoute r =
        interact::route_force(m, m.X, contact, force, {.locality = 2, .penetration_depth = p});
    ASSERT_EQ(static_cast<int32_t>(r.crossings.size()), p);
    std::set<int32_t> expected;
    for (const auto& cr : r.crossings) {
      const auto ring = ring_members(m, cr.node, 2);
      expected.insert(ring.begin(), ring.end());
    }
    EXPECT_EQ(std::set<int32_t>(r.nodes.begin(), r.nodes.end()), expected);
  }
  // P = 4: the far skin side receives force, pointing the same way, attenuated 0.95^3.
  const interact::ForceRoute all =
      interact::route_force(m, m.X, contact, force, {.locality = 1, .penetration_depth = 4});
  ASSERT_EQ(all.nodes.size(), 4u);
  const int32_t far = all.crossings[3].node;
  const auto it = std::find(all.nodes.begin(), all.nodes.end(), far);
  ASSERT_NE(it, all.nodes.end());
  const Eigen::Vector3d f_far = all.forces.row(it - all.nodes.begin());
  EXPECT_NEAR(f_far.norm(), 50.0 * std::pow(0.95, 3), 1e-9);
  EXPECT_GT(f_far.dot(force), 0.0);
}

TEST(RouteForce, RingsAreAttenuatedRingByRingAndTheTotalIsTheForce) {
  const Model& m = sphere_model();
  const Eigen::Vector3d force(0, 0, -10);
  const interact::ForceRoute r = interact::route_force(
      m, m.X, 10, force, {.locality = 3, .penetration_depth = 1, .ring_attenuation = 0.5});
  auto force_on = [&](int32_t node) -> Eigen::Vector3d {
    const auto it = std::find(r.nodes.begin(), r.nodes.end(), node);
    EXPECT_NE(it, r.nodes.end());
    return r.forces.row(it - r.nodes.begin());
  };
  const Eigen::Vector3d centre = force_on(10);
  EXPECT_GT(centre.dot(force), 0.0);
  for (int32_t ring = 0; ring < 3; ++ring)
    for (int64_t k = 0; k < m.rings.ring_size(10, ring); ++k)
      EXPECT_TRUE(force_on(m.rings.ring(10, ring)[k]).isApprox(centre * std::pow(0.5, ring)));
  // Spreading conserves the force: the total over all receiving nodes is the applied force.
  EXPECT_TRUE(Eigen::Vector3d(r.forces.colwise().sum()).isApprox(force));
  EXPECT_THROW(interact::route_force(m, m.X, 10, force, {.locality = m.rings.locality + 1}), Error);
}

TEST(RoutingOptions, EachBadValueIsNamedByItsKeyInOneCheck) {
  // One check for the scene reader, route_force, the realtime loop and Python: each bad value is
  // named by its scene key, and good options (the paper's) pass.
  const int32_t rings = 4;
  EXPECT_FALSE(interact::routing_problem({}, rings).has_value());
  const auto key = [&](const interact::RoutingOptions& o) {
    const auto p = interact::routing_problem(o, rings);
    return p ? p->key : std::string("none");
  };
  EXPECT_EQ(key({.locality = 0}), "locality");
  EXPECT_EQ(key({.locality = rings + 1}), "locality");
  EXPECT_EQ(key({.penetration_depth = 0}), "penetration_depth");
  EXPECT_EQ(key({.ring_attenuation = 1.5}), "ring_attenuation");
  EXPECT_EQ(key({.ring_attenuation = std::nan("")}), "ring_attenuation");
  EXPECT_EQ(key({.crossing_attenuation = -0.1}), "crossing_attenuation");
  EXPECT_EQ(key({.contact_threshold_mm = 0.0}), "contact_threshold_mm");
  EXPECT_EQ(key({.contact_threshold_mm = std::numeric_limits<double>::infinity()}),
            "contact_threshold_mm");
  try {
    interact::check_routing({.penetration_depth = 0}, rings);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(),
                 "solver.penetration_depth: must be at least 1 (the contact itself), got 0");
  }
}

TEST(NearestSkinNode, WithinThresholdOnly) {
  const Model& m = sphere_model();
  const Eigen::Vector3d p = m.X.row(7).transpose() + Eigen::Vector3d(0.1, 0, 0);
  EXPECT_EQ(interact::nearest_skin_node(m, m.X, p, 1.0), 7);
  EXPECT_EQ(interact::nearest_skin_node(m, m.X, p + Eigen::Vector3d(100, 0, 0), 1.0), -1);
}

TEST(ApplyTools, ActOnlyBetweenStartAndEndAndDriveLocalMode) {
  const Model& m = sphere_model();
  sim::Simulation s = sim::make_simulation(m, {}, {.mode = sim::Mode::kLocal});
  interact::ToolDriver d;
  d.tools.push_back(
      {.vertex = 3, .force_mn = Eigen::Vector3d(0, 0, 5), .start_s = 0.05, .end_s = 0.1});
  EXPECT_FALSE(interact::apply_tools(s, d));
  EXPECT_EQ(s.f_ext.squaredNorm(), 0.0);
  s.time_s = 0.06;
  EXPECT_TRUE(interact::apply_tools(s, d));
  EXPECT_GT(s.f_ext.squaredNorm(), 0.0);
  int movable = 0;
  for (uint8_t b : s.movable()) movable += b;
  EXPECT_EQ(movable, static_cast<int>(d.touched.size()));
  s.time_s = 0.1;
  EXPECT_FALSE(interact::apply_tools(s, d));
  EXPECT_EQ(s.f_ext.squaredNorm(), 0.0);
}

TEST(ApplyTools, TwoToolsAtOnceBothDeformTheSkin) {
  const Model& m =
      model::build_model(geometry::make_phantom({.spacing_mm = {3, 3, 3}}), {.skin_vertices = 400})
          .model;
  // Two anterior skin nodes far apart, on the right and the left lobe, both pushed backwards.
  // (Opposite tools would be a poor test: with P = 4 each one's force line exits through the
  // other's contact, as in the paper.)
  auto most_anterior = [&](double x_lo, double x_hi) {
    int32_t best = -1;
    for (int32_t i = 0; i < m.layers[0].node_count; ++i)
      if (m.X(i, 0) > x_lo && m.X(i, 0) < x_hi && (best < 0 || m.X(i, 1) < m.X(best, 1))) best = i;
    return best;
  };
  const int32_t right = most_anterior(-200, -60), left = most_anterior(40, 200);
  ASSERT_GE(right, 0);
  ASSERT_GE(left, 0);
  auto run = [&](bool both) {
    sim::Simulation s = sim::make_simulation(m, {.anchor_stiffness_n_per_m = 0.5});
    interact::ToolDriver d;
    d.tools.push_back({.vertex = right, .force_mn = Eigen::Vector3d(0, 20, 0)});
    if (both) d.tools.push_back({.vertex = left, .force_mn = Eigen::Vector3d(0, 20, 0)});
    for (int k = 0; k < 200; ++k) {
      interact::apply_tools(s, d);
      sim::step(s);
    }
    return Eigen::Vector2d(s.x(right, 1) - m.X(right, 1), s.x(left, 1) - m.X(left, 1));
  };
  const Eigen::Vector2d one = run(false), two = run(true);
  EXPECT_GT(two[0], 0.3);  // both contacts pushed backwards at the same time
  EXPECT_GT(two[1], 0.3);
  EXPECT_LT(std::abs(one[1]), 0.2 * two[1]);  // without the second tool its contact hardly moves
}

}  // namespace
