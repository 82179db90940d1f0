// Touch on the fine surface (issue 33, item 3): on a model with a display skin, tools without
// routing find their contact on it, and its load reaches the nodes by the embedding's weights
// (W transposed) with the same total force and the same moment; the haptic proxy rests on it at
// its radius, and its neighbour list over it renders exactly what a whole scan every step does.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <iostream>
#include <limits>
#include <tuple>
#include <vector>

#include "lamina/geometry/closest_on_triangle.h"
#include "lamina/interact/contact.h"
#include "lamina/interact/haptic_proxy.h"
#include "lamina/interact/tools.h"
#include "lamina/model/embed_surface.h"
#include "lamina/sim/simulation.h"
#include "support/embedded_phantom.h"
#include "support/held_sphere.h"
#include "support/random_rows.h"

namespace {

using namespace lamina;

// Distance from p to the triangles F over the points V, by brute force.
double distance_to(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, const Eigen::Vector3d& p,
                   Eigen::Vector3d* nearest = nullptr) {
  double best = std::numeric_limits<double>::infinity();
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    const Eigen::Vector3d w = geometry::closest_on_triangle(p, a, b, c);
    const Eigen::Vector3d q = w[0] * a + w[1] * b + w[2] * c;
    if ((q - p).norm() < best) {
      best = (q - p).norm();
      if (nearest) *nearest = q;
    }
  }
  return best;
}

// The skin (layer 0) of the model at positions x, as a point set for distance_to.
double distance_to_skin(const Model& m, const Eigen::MatrixX3d& x, const Eigen::Vector3d& p) {
  return distance_to(x, m.layers[0].F, p);
}

const EmbeddedSurface& display_skin(const Model& m) {
  const int32_t k = model::display_skin_index(m);
  EXPECT_GE(k, 0);
  return m.embedded.at(static_cast<size_t>(k));
}

// The display-skin vertex farthest along -y (the phantom's front) and its outward direction there.
int32_t front_vertex(const EmbeddedSurface& e) {
  Eigen::Index v = 0;
  e.V.col(1).minCoeff(&v);
  return static_cast<int32_t>(v);
}

Eigen::Vector3d moment(const Eigen::MatrixX3d& x, const interact::ForceRoute& r) {
  Eigen::Vector3d m = Eigen::Vector3d::Zero();
  for (size_t k = 0; k < r.nodes.size(); ++k)
    m +=
        x.row(r.nodes[k]).transpose().cross(r.forces.row(static_cast<Eigen::Index>(k)).transpose());
  return m;
}

TEST(TouchSurface, APointLoadOnTheDisplaySkinReachesTheNodesWithItsForceAndMoment) {
  const Model& m = test::embedded_phantom();
  const EmbeddedSurface& e = display_skin(m);
  const Eigen::MatrixX3d x = test::jiggle(m.X, 0.8, 7);  // a deformed shape, not the rest one
  Eigen::MatrixX3d shown;
  model::embedded_positions(e, x, shown);
  const interact::RoutingOptions none{.routing = interact::Routing::kNone};
  const Eigen::Vector3d force(30.0, 120.0, -45.0);  // mN
  int checked = 0, off_the_skin = 0;
  // Points 1.5 mm outside every 97th display-skin vertex: outward from the organ's centre.
  const Eigen::Vector3d centre = shown.colwise().mean().transpose();
  for (Eigen::Index v = 0; v < shown.rows(); v += 97) {
    const Eigen::Vector3d out = (shown.row(v).transpose() - centre).normalized();
    const Eigen::Vector3d p = shown.row(v).transpose() + 1.5 * out;
    Eigen::Vector3d q;
    const double d = distance_to(shown, e.F, p, &q);
    const interact::ForceRoute r = interact::load_at_point(m, x, p, force, 0.0, none);
    ASSERT_FALSE(r.nodes.empty()) << "vertex " << v;
    // The same force, and the moment of that force applied at the display skin's point q.
    EXPECT_LT((interact::total_force(r) - force).norm(), 1e-9 * force.norm()) << "vertex " << v;
    EXPECT_LT((moment(x, r) - q.cross(force)).norm(), 1e-9 * q.norm() * force.norm())
        << "vertex " << v << ": the load acts at the display skin's nearest point";
    off_the_skin += distance_to_skin(m, x, p) > d + 0.2;
    ++checked;
  }
  std::cout << checked << " points, " << off_the_skin
            << " of them > 0.2 mm nearer the display skin than the simulation's skin\n";
  EXPECT_GT(off_the_skin, checked / 4) << "the contact is on the display skin, not layer 0";

  // Asked for the skin, the same point load acts on the simulation's skin instead.
  const Eigen::Vector3d p = shown.row(front_vertex(e)).transpose() + Eigen::Vector3d(0, -1.0, 0);
  interact::RoutingOptions skin = none;
  skin.touch = interact::Touch::kSkin;
  const interact::ForceRoute r = interact::load_at_point(m, x, p, force, 0.0, skin);
  for (const int32_t n : r.nodes) EXPECT_LT(n, m.layers[0].node_count) << "a skin node";
  Eigen::Vector3d q;
  distance_to(x, m.layers[0].F, p, &q);
  EXPECT_LT((moment(x, r) - q.cross(force)).norm(), 1e-9 * q.norm() * force.norm());
}

// The phantom as soft tissue at 1 ms (implicit Euler), its back half held.
sim::Simulation phantom_tissue(const Model& m) {
  sim::Simulation s = test::soft_tissue(m);
  const double middle = 0.5 * (m.X.col(1).minCoeff() + m.X.col(1).maxCoeff());
  std::vector<int32_t> held;
  for (int32_t i = 0; i < m.node_count(); ++i)
    if (m.X(i, 1) > middle) held.push_back(i);
  sim::fix_nodes(s, held);
  return s;
}

TEST(TouchSurface, TheHapticProxyRestsOnTheDisplaySkinAndItsListMatchesAWholeScan) {
  const Model& m = test::embedded_phantom();
  const EmbeddedSurface& e = display_skin(m);
  const Eigen::Vector3d front = e.V.row(front_vertex(e)).transpose();
  const interact::RoutingOptions none{.routing = interact::Routing::kNone};
  const interact::ToolTip tip{.active = true, .radius_mm = 4.0, .stiffness_n_per_m = 200.0};
  sim::Simulation kept = phantom_tissue(m), scanned = phantom_tissue(m);
  interact::HapticProxy with_list, every_step;
  interact::Loads kept_loads, scanned_loads;
  Eigen::MatrixX3d shown;
  double worst_rest_error = 0.0, worst_third_law = 0.0, skin_gap = 0.0;
  int touching = 0;
  for (int k = 0; k < 600; ++k) {
    // In 12 mm over 0.2 s (8 mm past the display skin), sideways 6 mm, and out again.
    const double s = k < 200 ? k / 200.0 : k < 400 ? 1.0 : (600 - k) / 200.0;
    interact::ToolTip t = tip;
    t.center_mm = front + Eigen::Vector3d(k >= 200 ? 6.0 * std::min(k - 200, 200) / 200.0 : 0.0,
                                          -8.0 + 12.0 * s, 0.0);
    every_step.near.reach_mm = -1.0;  // forgets its list: the whole display skin every step
    const interact::ForceRoute a = interact::load_of_tip(m, kept.x, t, none, with_list);
    const interact::ForceRoute b = interact::load_of_tip(m, scanned.x, t, none, every_step);
    ASSERT_EQ(a.nodes, b.nodes) << "step " << k;
    ASSERT_EQ(a.forces, b.forces) << "step " << k;
    ASSERT_EQ(with_list.proxy_mm, every_step.proxy_mm) << "step " << k;
    if (with_list.touching) {
      ++touching;
      model::embedded_positions(e, kept.x, shown);
      worst_rest_error = std::max(
          worst_rest_error, std::abs(distance_to(shown, e.F, with_list.proxy_mm) - t.radius_mm));
      if (!a.nodes.empty())
        worst_third_law = std::max(worst_third_law,
                                   (interact::total_force(a) + with_list.device_force_mn).norm());
      skin_gap = std::max(skin_gap, distance_to_skin(m, kept.x, with_list.proxy_mm) - t.radius_mm);
    }
    for (auto [on, load, loads] :
         {std::tuple{&kept, &a, &kept_loads}, std::tuple{&scanned, &b, &scanned_loads}}) {
      interact::clear_loads(*on, *loads);
      interact::add_load(*on, *load, *loads);
      ASSERT_EQ(sim::step(*on).unstable, sim::Instability::kNone) << "step " << k;
    }
  }
  std::cout << touching << " steps touching; the proxy's distance to the display skin within "
            << worst_rest_error << " mm of its radius; up to " << skin_gap
            << " mm farther from the simulation's skin; " << with_list.near.scans
            << " scans with the list, " << every_step.near.scans << " without\n";
  EXPECT_GT(touching, 300);
  EXPECT_LT(worst_rest_error, 1e-6 * tip.radius_mm) << "it rests on the display skin";
  EXPECT_LT(worst_third_law, 1e-9 * 1000.0 * tip.max_force_n) << "the tissue takes minus it";
  EXPECT_GT(skin_gap, 0.2) << "not on the simulation's skin";
  EXPECT_EQ(kept.x, scanned.x);
  EXPECT_LT(with_list.near.scans, 60) << "a scan per few mm travelled, not per step";
}

}  // namespace
