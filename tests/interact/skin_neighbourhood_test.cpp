// The skin's neighbour list (skin_neighbourhood.h): whatever the point and the skin do, every
// triangle within reach is listed; the whole skin is scanned again only when they have moved
// the margin; and the haptic tip with its list renders exactly what it renders scanning the
// whole skin every step.
#include "lamina/interact/skin_neighbourhood.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <vector>

#include "lamina/interact/haptic_proxy.h"
#include "lamina/interact/tools.h"
#include "support/held_sphere.h"
#include "support/random_rows.h"
#include "support/sphere_model.h"

namespace {

using namespace lamina;

// Every skin triangle with a point within reach of centre (by its closest point).
std::vector<int32_t> within_reach(const Model& m, const Eigen::MatrixX3d& x,
                                  const Eigen::Vector3d& centre, double reach) {
  std::vector<int32_t> out;
  const Eigen::MatrixX3i& F = m.layers[0].F;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = x.row(F(f, 0)), b = x.row(F(f, 1)), c = x.row(F(f, 2));
    // Sampled densely: a point of the triangle within reach puts it in the set.
    bool in = false;
    for (int i = 0; i <= 20 && !in; ++i)
      for (int j = 0; i + j <= 20 && !in; ++j)
        in = ((a + (i / 20.0) * (b - a) + (j / 20.0) * (c - a)) - centre).norm() <= reach;
    if (in) out.push_back(static_cast<int32_t>(f));
  }
  return out;
}

TEST(SkinNeighbourhood, ListsEveryTriangleWithinReachAndScansOnlyWhenTheMarginIsSpent) {
  Eigen::Vector3d c;
  const Model& m = test::sphere_model(&c);
  const Eigen::Vector3d skin = m.X.row(test::front_node(m)).transpose();
  interact::SkinNeighbourhood near;
  const int queries = 400;
  const Eigen::MatrixX3d field = test::random_rows(m.node_count(), 1.5, 1);
  Eigen::MatrixX3d x = m.X;
  for (int k = 0; k < queries; ++k) {
    // The point walks about 0.1 mm a query around the front of the sphere; the skin breathes,
    // every node up to 1.5 mm from rest, and every 100 queries shifts 6 mm (more than the
    // margin) for one query.
    const double t = 0.1 * k;
    const Eigen::Vector3d centre = skin + Eigen::Vector3d(10.0 * std::sin(t / 8.0), -2.0, t / 10.0);
    x = m.X + std::sin(t) * field;
    if (k % 100 == 99) x.col(0).array() += 6.0;
    const double reach = 7.0;
    const std::vector<int32_t>& listed = interact::skin_faces_near(m, x, centre, reach, near);
    ASSERT_TRUE(std::is_sorted(listed.begin(), listed.end()));
    for (const int32_t f : within_reach(m, x, centre, reach))
      ASSERT_TRUE(std::binary_search(listed.begin(), listed.end(), f))
          << "query " << k << ": triangle " << f << " is within reach and not listed";
    ASSERT_LT(listed.size(), static_cast<size_t>(m.layers[0].F.rows())) << "a local list";
  }
  // The breathing and the walk spend the 3.5 mm margin every few dozen queries, each shift
  // twice (there and back).
  EXPECT_LT(near.scans, queries / 8) << near.scans << " scans in " << queries << " queries";
  std::cout << near.scans << " scans in " << queries << " queries\n";
  EXPECT_GE(near.scans, 8) << "each sudden shift past the margin scans again, there and back";
}

TEST(SkinNeighbourhood, TheHapticTipRendersExactlyAsWithAWholeSkinScanEveryStep) {
  Eigen::Vector3d c;
  const Model& m = test::sphere_model(&c);
  const Eigen::Vector3d skin = m.X.row(test::front_node(m)).transpose();
  const interact::RoutingOptions none{.routing = interact::Routing::kNone};
  const interact::ToolTip tip{.active = true, .radius_mm = 5.0, .stiffness_n_per_m = 200.0};
  // One tissue, queried both ways every step: identical loads from the same state are the same
  // rendering (two simulations stepped side by side cost twice as much and, deterministic, could
  // only stay bit-identical too).
  sim::Simulation tissue = test::tissue_sphere();
  interact::HapticProxy with_list, every_step;
  interact::Loads loads;
  double dented = 0.0;
  for (int k = 0; k < 600; ++k) {
    // In 10 mm over 0.2 s, sideways 6 mm, and out again (50 mm/s).
    const double s = k < 200 ? k / 200.0 : k < 400 ? 1.0 : (600 - k) / 200.0;
    interact::ToolTip t = tip;
    t.center_mm = skin + Eigen::Vector3d(k >= 200 ? 6.0 * std::min(k - 200, 200) / 200.0 : 0.0,
                                         -8.0 + 10.0 * s, 0.0);
    every_step.near.reach_mm = -1.0;  // forgets its list: the whole skin every step
    const interact::ForceRoute a = interact::load_of_tip(m, tissue.x, t, none, with_list);
    const interact::ForceRoute b = interact::load_of_tip(m, tissue.x, t, none, every_step);
    ASSERT_EQ(a.nodes, b.nodes) << "step " << k;
    ASSERT_EQ(a.forces, b.forces) << "step " << k;
    ASSERT_EQ(with_list.device_force_mn, every_step.device_force_mn) << "step " << k;
    ASSERT_EQ(with_list.proxy_mm, every_step.proxy_mm) << "step " << k;
    interact::clear_loads(tissue, loads);
    interact::add_load(tissue, a, loads);
    sim::step(tissue);
    if (k == 199) dented = (tissue.x - m.X).rowwise().norm().maxCoeff();
  }
  EXPECT_GT(dented, 1.0) << "the tip dented the tissue";
  EXPECT_LT(with_list.near.scans, 30) << "the tip moved 26 mm: a scan per few mm, not per step";
  EXPECT_GE(every_step.near.scans, 500);
  std::cout << "scans: " << with_list.near.scans << " with the list, " << every_step.near.scans
            << " without, in 600 steps\n";
}

}  // namespace
