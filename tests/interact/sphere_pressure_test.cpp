// The sphere tool's contact law (interact::press_sphere) against the closed form on a plane.
#include "lamina/interact/sphere_pressure.h"

#include <gtest/gtest.h>

#include <cmath>

namespace {

using namespace lamina;

// A square of side `size` on z = 0 centred at the origin, cut into `cells` x `cells` squares of
// two triangles each, facing +z.
struct Plane {
  Eigen::MatrixX3d x;
  Eigen::MatrixX3i F;
};
Plane plane(double size, int cells) {
  Plane p;
  const int n = cells + 1;
  p.x.resize(n * n, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      p.x.row(i * n + j) << -0.5 * size + size * i / cells, -0.5 * size + size * j / cells, 0.0;
  p.F.resize(2 * cells * cells, 3);
  for (int i = 0, f = 0; i < cells; ++i)
    for (int j = 0; j < cells; ++j) {
      const int a = i * n + j, b = a + n, c = a + 1, d = b + 1;
      p.F.row(f++) << a, b, d;
      p.F.row(f++) << a, d, c;
    }
  return p;
}

// A sphere of radius r whose centre is h = r - p above a plane pushes it with the integral over
// the cap's disc of pressure(r - d) h / d (d: distance to the centre, rho the disc's radius):
// d d = rho d rho turns it into 2 pi h * integral from h to r of pressure(r - d) dd. With the
// pressure k (depth - s/2) past the rim band s and k depth^2 / (2 s) in it, that is
// 2 pi h k [s^2 / 6 + (p - s)^2 / 2 + s (p - s) / 2] for p >= s (pi k h p^2 without the band).
double plane_push(double k, double r, double p) {
  const double s = interact::kSphereRimFraction * r;
  if (p < s) return 2.0 * M_PI * (r - p) * k * p * p * p / (6.0 * s);
  return 2.0 * M_PI * (r - p) * k * (s * s / 6.0 + 0.5 * (p - s) * (p - s) + 0.5 * s * (p - s));
}

TEST(SpherePressure, PushesAPlaneAsTheClosedFormAlongItsNormal) {
  const Plane pl = plane(60.0, 30);  // 2 mm cells
  std::vector<interact::PressedPiece> pieces;
  for (double p : {1.0, 3.0, 6.0}) {
    const interact::PressingSphere s{.center_mm = Eigen::Vector3d(0.3, -0.7, 10.0 - p),
                                     .radius_mm = 10.0,
                                     .stiffness_kpa_per_mm = 2.0};
    interact::press_sphere(pl.x, pl.x, pl.F, s, pieces);
    const Eigen::Vector3d total = interact::pressed_total(pieces);
    SCOPED_TRACE(p);
    EXPECT_NEAR(-total.z(), plane_push(2.0, 10.0, p), 0.01 * plane_push(2.0, 10.0, p));
    EXPECT_LT(total.head<2>().norm(), 0.01 * -total.z()) << "no shear from a centred press";
    for (const interact::PressedPiece& q : pieces) {
      EXPECT_LT(q.normal.z(), 0.0);  // out of the sphere: down into the plane
      EXPECT_NEAR(q.barycentric.sum(), 1.0, 1e-12);
      EXPECT_GT(q.stiffness_mn_per_mm, 0.0);
    }
  }
  // Not touching: nothing pressed.
  interact::press_sphere(pl.x, pl.x, pl.F,
                         {.center_mm = Eigen::Vector3d(0, 0, 10.5), .radius_mm = 10.0}, pieces);
  EXPECT_TRUE(pieces.empty());
}

TEST(SpherePressure, TheForceIsContinuousAsTheSphereMoves) {
  const Plane pl = plane(60.0, 12);  // 5 mm cells: pieces cut finer than the triangles
  std::vector<interact::PressedPiece> pieces;
  interact::PressingSphere s{.center_mm = Eigen::Vector3d(0.0, 0.0, 7.0), .radius_mm = 10.0};
  double last = 0.0;
  for (int k = 0; k <= 200; ++k) {  // across triangle edges, 0.05 mm at a time
    s.center_mm.x() = 0.05 * k;
    interact::press_sphere(pl.x, pl.x, pl.F, s, pieces);
    const double push = -interact::pressed_total(pieces).z();
    if (k > 0) EXPECT_NEAR(push, last, 0.01 * last) << "at x = " << s.center_mm.x();
    last = push;
  }
}

TEST(SpherePressure, FindsWhereTheSphereFirstTouchesAndRefusesAStartInside) {
  const Plane pl = plane(60.0, 6);
  const Eigen::Vector3d down(0.0, 0.0, -1.0);
  const auto touch =
      interact::sphere_first_touch(pl.x, pl.F, Eigen::Vector3d(1, 2, 50), down, 10.0, 100.0);
  ASSERT_TRUE(touch);
  EXPECT_NEAR(touch->z(), 10.0, 1e-6);
  EXPECT_FALSE(
      interact::sphere_first_touch(pl.x, pl.F, Eigen::Vector3d(1, 2, 5), down, 10.0, 100.0))
      << "starting in contact";
  EXPECT_FALSE(
      interact::sphere_first_touch(pl.x, pl.F, Eigen::Vector3d(1, 2, 50), -down, 10.0, 100.0))
      << "moving away";
  EXPECT_TRUE(interact::sphere_problem({.radius_mm = 0.0}));
  EXPECT_TRUE(interact::sphere_problem({.stiffness_kpa_per_mm = -1.0}));
  EXPECT_TRUE(interact::sphere_problem({.center_mm = Eigen::Vector3d(0, std::nan(""), 0)}));
  EXPECT_FALSE(interact::sphere_problem({}));
}

}  // namespace
