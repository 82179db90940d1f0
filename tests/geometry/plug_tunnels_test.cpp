#include "lamina/geometry/plug_tunnels.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "lamina/core/grid.h"

namespace {

using namespace lamina;

// A 40^3 grid of 1 mm voxels with the voxels where `in(i, j, k)` holds.
Mask shape(const std::function<bool(double, double, double)>& in) {
  Mask m;
  m.frame.size = {40, 40, 40};
  m.inside.assign(static_cast<size_t>(m.frame.voxel_count()), 0);
  for (int64_t k = 0; k < 40; ++k)
    for (int64_t j = 0; j < 40; ++j)
      for (int64_t i = 0; i < 40; ++i)
        m.inside[static_cast<size_t>(m.frame.index(i, j, k))] =
            in(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k));
  return m;
}

bool box(double i, double j, double k) {
  return i >= 8 && i < 32 && j >= 8 && j < 32 && k >= 8 && k < 32;
}

// A hole of `radius` along k through the box, centred at (ci, cj).
auto holed(double ci, double cj, double radius) {
  return [=](double i, double j, double k) {
    return box(i, j, k) && std::hypot(i - ci, j - cj) > radius;
  };
}

int64_t count(const Mask& m) {
  int64_t n = 0;
  for (const uint8_t v : m.inside) n += v;
  return n;
}

TEST(PlugTunnels, TheEulerCharacteristicCountsTunnels) {
  EXPECT_EQ(geometry::euler_characteristic(shape(box)), 1);                 // a ball
  EXPECT_EQ(geometry::euler_characteristic(shape(holed(20, 20, 2.5))), 0);  // a ring
  const auto two = [](double i, double j, double k) {
    return holed(14, 20, 2.5)(i, j, k) && std::hypot(i - 26, j - 20) > 2.5;
  };
  EXPECT_EQ(geometry::euler_characteristic(shape(two)), -1);  // two tunnels
  // A hollow box: one component, one cavity.
  const auto hollow = [](double i, double j, double k) {
    return box(i, j, k) && !(i >= 14 && i < 26 && j >= 14 && j < 26 && k >= 14 && k < 26);
  };
  EXPECT_EQ(geometry::euler_characteristic(shape(hollow)), 2);
}

TEST(PlugTunnels, ANarrowTunnelIsPluggedAndNothingElseChanges) {
  // A 5 mm tunnel through the box and a groove along one face: the tunnel is filled (the box
  // is whole again there), the groove keeps its shape (filling it changes no topology).
  const auto with_groove = [](double i, double j, double k) {
    return holed(20, 20, 2.5)(i, j, k) && !(i >= 18 && i < 22 && j >= 29);
  };
  Mask m = shape(with_groove);
  const Mask before = m;
  std::vector<uint8_t> added;
  const geometry::TunnelPlugs p = geometry::plug_tunnels(m, 4.0, &added);
  EXPECT_EQ(p.tunnels_before, 1);
  EXPECT_EQ(p.tunnels_after, 0);
  EXPECT_EQ(p.plugs, 1);
  EXPECT_EQ(geometry::euler_characteristic(m), 1);
  EXPECT_LE(p.radius_mm, 4.0);
  for (int64_t k = 0; k < 40; ++k)
    for (int64_t j = 0; j < 40; ++j)
      for (int64_t i = 0; i < 40; ++i) {
        const size_t v = static_cast<size_t>(m.frame.index(i, j, k));
        const bool in_tunnel =
            box(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k)) &&
            std::hypot(i - 20.0, j - 20.0) <= 2.5;
        // A closing leaves a dimple at a tunnel's mouths, no deeper than the ball's radius.
        if (in_tunnel && k >= 12 && k < 28) EXPECT_TRUE(m.inside[v]) << i << " " << j << " " << k;
        if (!in_tunnel) EXPECT_EQ(m.inside[v], before.inside[v]) << i << " " << j << " " << k;
        EXPECT_EQ(added[v], m.inside[v] && !before.inside[v]);
      }
  EXPECT_EQ(p.voxels, count(m) - count(before));
  EXPECT_NEAR(p.volume_ml, static_cast<double>(p.voxels) / 1000.0, 1e-12);
}

TEST(PlugTunnels, ATunnelWiderThanTheBallIsKept) {
  Mask m = shape(holed(20, 20, 6.0));
  const geometry::TunnelPlugs p = geometry::plug_tunnels(m, 3.0);
  EXPECT_EQ(p.tunnels_before, 1);
  EXPECT_EQ(p.tunnels_after, 1);
  EXPECT_EQ(p.plugs, 0);
  EXPECT_EQ(p.voxels, p.corner_voxels) << "nothing but the corners a voxel touches alone";
  EXPECT_EQ(geometry::euler_characteristic(m), 0);
}

TEST(PlugTunnels, TunnelsThroughCornersAloneAreFoundAndTheMaskMadeWellComposed) {
  // A ring whose voxels touch by edges alone at four places (a diamond in the k = 20 plane):
  // no face-connected tunnel, but one through its corners, which an isosurface may join.
  Mask m = shape([](double i, double j, double k) {
    return k == 20 && std::abs(std::abs(i - 20) + std::abs(j - 20) - 6) < 0.5;
  });
  EXPECT_EQ(geometry::euler_characteristic(m, true), 0);  // a ring through its edges
  EXPECT_GT(geometry::euler_characteristic(m), 1);        // but pieces by faces
  Mask w = m;
  EXPECT_GT(geometry::make_well_composed(w), 0);
  // Well-composed: faces and corners agree.
  EXPECT_EQ(geometry::euler_characteristic(w), geometry::euler_characteristic(w, true));
  EXPECT_EQ(geometry::euler_characteristic(w), 0);
}

TEST(PlugTunnels, AnOrganWithoutTunnelsIsReturnedAsItWas) {
  // Concave, with a deep dent: no tunnel, nothing to do, even with a large ball.
  const auto dented = [](double i, double j, double k) {
    return box(i, j, k) && !(std::hypot(i - 20, j - 20) < 4 && k >= 20);
  };
  Mask m = shape(dented);
  const Mask before = m;
  const geometry::TunnelPlugs p = geometry::plug_tunnels(m, 8.0);
  EXPECT_EQ(p.tunnels_before, 0);
  EXPECT_EQ(p.plugs, 0);
  EXPECT_EQ(m.inside, before.inside);
}

}  // namespace
