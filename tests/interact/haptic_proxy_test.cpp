// The haptic tip: a god-object proxy that stays outside the skin and a virtual coupling whose
// force is bounded, changes by a bounded step, is exactly minus the tissue's load, and over a
// closed device path through the tissue returns no more energy than was put in (passive).
#include "lamina/interact/haptic_proxy.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "lamina/core/error.h"
#include "support/held_sphere.h"
#include "support/sphere_model.h"

namespace {

using namespace lamina;

using test::front_node;
using test::sphere_model;

const interact::RoutingOptions kNoRouting{.routing = interact::Routing::kNone};

using test::tissue_sphere;

struct Rendered {
  std::vector<Eigen::Vector3d> device, force;  // per step: where the device was, its force (mN)
  double work_mj = 0.0;    // sum of force . (next device - device): > 0 means energy returned
  double put_in_mj = 0.0;  // the user's work against the force
  double largest_mn = 0.0, largest_change_mn = 0.0, worst_third_law_mn = 0.0;
  bool crossed = false;  // the proxy went past the sphere's centre plane
};

// Drives the tip along `path` (one device position per 1 ms step) on the sphere.
Rendered render_path(sim::Simulation& s, interact::ToolTip tip,
                     const std::vector<Eigen::Vector3d>& path, double centre_y) {
  const Model& m = s.model();
  interact::HapticProxy proxy;
  interact::Loads loads;
  Rendered out;
  Eigen::Vector3d last = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& d : path) {
    tip.center_mm = d;
    interact::clear_loads(s, loads);
    const interact::ForceRoute load = interact::load_of_tip(m, s.x, tip, kNoRouting, proxy);
    interact::add_load(s, load, loads);
    EXPECT_EQ(sim::step(s).unstable, sim::Instability::kNone);
    const Eigen::Vector3d f = proxy.device_force_mn;
    if (!load.nodes.empty())
      out.worst_third_law_mn =
          std::max(out.worst_third_law_mn, (interact::total_force(load) + f).norm());
    out.largest_mn = std::max(out.largest_mn, f.norm());
    out.largest_change_mn = std::max(out.largest_change_mn, (f - last).norm());
    out.crossed = out.crossed || proxy.proxy_mm.y() > centre_y;
    last = f;
    out.device.push_back(d);
    out.force.push_back(f);
  }
  for (size_t k = 0; k + 1 < out.device.size(); ++k) {
    // mN x mm = uJ; 1e-3 of that in mJ.
    const double w = 1e-3 * out.force[k].dot(out.device[k + 1] - out.device[k]);
    out.work_mj += w;
    out.put_in_mj += std::max(-w, 0.0);
  }
  return out;
}

// In along -y -> +y at `speed` to `depth` past the skin, sideways, and back out the same way.
std::vector<Eigen::Vector3d> closed_path(const Eigen::Vector3d& skin, double depth,
                                         double speed_mm_per_s) {
  const double step = speed_mm_per_s * 1e-3;
  const Eigen::Vector3d start = skin - Eigen::Vector3d(0, 8, 0);
  const Eigen::Vector3d corners[] = {start, skin + Eigen::Vector3d(0, depth - 5.0, 0),
                                     skin + Eigen::Vector3d(4, depth - 5.0, 0), start};
  std::vector<Eigen::Vector3d> path;
  for (int leg = 0; leg < 3; ++leg) {
    const Eigen::Vector3d a = corners[leg], b = corners[leg + 1];
    const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / step)));
    for (int k = 0; k < n; ++k) path.push_back(a + (static_cast<double>(k) / n) * (b - a));
  }
  for (int k = 0; k < 500; ++k) path.push_back(start);  // and rest outside
  return path;
}

TEST(HapticProxy, AClosedPathThroughTheTissueReturnsNoMoreEnergyThanWasPutIn) {
  Eigen::Vector3d c;
  const Model& m = sphere_model(&c);
  const Eigen::Vector3d skin = m.X.row(front_node(m)).transpose();
  for (double speed : {20.0, 100.0}) {
    sim::Simulation s = tissue_sphere();
    const interact::ToolTip tip{.active = true, .radius_mm = 5.0, .stiffness_n_per_m = 200.0};
    const Rendered r = render_path(s, tip, closed_path(skin, 4.0, speed), c.y());
    EXPECT_GT(r.put_in_mj, 0.0) << "the device pushed against the tissue";
    EXPECT_LE(r.work_mj, 0.0) << speed << " mm/s: returned " << r.work_mj << " mJ of "
                              << r.put_in_mj << " put in";
    EXPECT_LE(r.largest_mn, 3000.0 + 1e-9);
    EXPECT_LE(r.largest_change_mn, 50.0 + 1e-9);
    EXPECT_LT(r.worst_third_law_mn, 1e-9) << "the tissue takes exactly minus the device's force";
    EXPECT_FALSE(r.crossed);
    EXPECT_EQ(r.force.back(), Eigen::Vector3d::Zero()) << "off the skin, no force";
  }
}

TEST(HapticProxy, AStiffCouplingIsBoundedAndRateLimitedAndTheProxyNeverCrosses) {
  Eigen::Vector3d c;
  const Model& m = sphere_model(&c);
  const Eigen::Vector3d skin = m.X.row(front_node(m)).transpose();
  sim::Simulation s = tissue_sphere();
  // 2000 N/m at 200 mm/s asks for 400 mN more each step; 50 mN a step is allowed. 15 mm in,
  // the soft sphere pushes back with about 1 N: a 0.5 N device bound is reached and held.
  const interact::ToolTip tip{
      .active = true, .radius_mm = 5.0, .stiffness_n_per_m = 2000.0, .max_force_n = 0.5};
  const std::vector<Eigen::Vector3d> path = closed_path(skin, 15.0, 200.0);
  const Rendered r = render_path(s, tip, path, c.y());
  EXPECT_NEAR(r.largest_mn, 500.0, 1e-6) << "the bound is reached and held";
  EXPECT_LE(r.largest_change_mn, 50.0 + 1e-9);
  EXPECT_FALSE(r.crossed) << "the proxy stays on the side it came from";
  EXPECT_LT(r.worst_third_law_mn, 1e-9);
}

TEST(HapticProxy, ADeviceInsideTheOrganIsNotPlacedUntilBroughtOut) {
  // From inside, the nearest surface may be the far side's: the proxy waits, nothing is felt
  // or loaded, and it is placed on the device's side once the device is outside.
  Eigen::Vector3d c;
  const Model& m = sphere_model(&c);
  const Eigen::Vector3d skin = m.X.row(front_node(m)).transpose();
  const Eigen::Vector3d outward = (skin - c).normalized();
  interact::ToolTip tip{.active = true, .center_mm = c, .radius_mm = 5.0};
  interact::HapticProxy proxy;
  EXPECT_TRUE(interact::couple_proxy(m, m.X, tip, proxy).nodes.empty());
  EXPECT_FALSE(proxy.placed);
  EXPECT_TRUE(proxy.started_inside);
  EXPECT_NEAR(proxy.start_depth_mm, (skin - c).norm(), 0.1 * (skin - c).norm());
  EXPECT_TRUE(proxy.device_force_mn.isZero());
  tip.center_mm = skin - 8.0 * outward;  // still 8 mm under the skin, deeper than the radius
  for (int k = 0; k < interact::kInsideRecheckSteps; ++k)
    interact::couple_proxy(m, m.X, tip, proxy);
  EXPECT_TRUE(proxy.started_inside);
  EXPECT_NEAR(proxy.start_depth_mm, 8.0, 0.5) << "checked again within kInsideRecheckSteps";
  tip.center_mm = skin + 2.0 * outward;  // out, within the tip's radius of the skin: it touches
  int steps = 0;
  while (!proxy.placed && steps++ < interact::kInsideRecheckSteps)
    interact::couple_proxy(m, m.X, tip, proxy);
  EXPECT_TRUE(proxy.placed);
  EXPECT_FALSE(proxy.started_inside);
  EXPECT_GT((proxy.proxy_mm - c).dot(outward), (skin - c).norm()) << "placed on the near side";
}

}  // namespace
