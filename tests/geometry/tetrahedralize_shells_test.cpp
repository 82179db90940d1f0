// Tetrahedra between nested surfaces (TetGen behind geometry::tetrahedralize_shells) and their
// measures (geometry::measure_tets).
#include "lamina/geometry/tetrahedralize_shells.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>

#include "lamina/core/error.h"
#include "lamina/geometry/measure_tets.h"
#include "support/meshes.h"

namespace {

using namespace lamina;

// Two surfaces, the second nested in the first, as one vertex and triangle list.
struct Nested {
  Eigen::MatrixX3d V;
  Eigen::MatrixX3i F;
  std::vector<int32_t> surface;
};

Nested nested(const SurfaceMesh& outer, const SurfaceMesh& inner) {
  Nested n;
  n.V.resize(outer.V.rows() + inner.V.rows(), 3);
  n.V << outer.V, inner.V;
  n.F.resize(outer.F.rows() + inner.F.rows(), 3);
  n.F << outer.F, (inner.F.array() + static_cast<int>(outer.V.rows())).matrix();
  n.surface.assign(static_cast<size_t>(outer.F.rows()), 0);
  n.surface.insert(n.surface.end(), static_cast<size_t>(inner.F.rows()), 1);
  return n;
}

TEST(TetrahedralizeShells, FillsTheShellAndTheCoreConformingToBothSurfaces) {
  const Nested n = nested(test::octahedron(10.0), test::octahedron(4.0));
  const geometry::ShellTets st = geometry::tetrahedralize_shells(n.V, n.F, n.surface);
  ASSERT_GT(st.T.rows(), 0);
  Eigen::MatrixX3d all(n.V.rows() + st.interior_points.rows(), 3);
  all << n.V, st.interior_points;
  // Every tetrahedron positive; their volumes fill the outer octahedron (4/3 r^3) exactly.
  const geometry::TetQuality q = geometry::measure_tets(all, st.T);
  EXPECT_EQ(q.inverted, 0);
  EXPECT_NEAR(q.volume_mm3, 4.0 / 3.0 * 1000.0, 1e-9);
  // Each input triangle is a face: of one tetrahedron (outer surface) or two (inner), and the
  // tetrahedra just inside the inner surface are region 1, those between the two region 0.
  std::map<std::array<int, 3>, std::vector<int32_t>> regions;
  for (Eigen::Index t = 0; t < st.T.rows(); ++t)
    for (int c = 0; c < 4; ++c) {
      std::array<int, 3> f{st.T(t, (c + 1) % 4), st.T(t, (c + 2) % 4), st.T(t, (c + 3) % 4)};
      std::sort(f.begin(), f.end());
      regions[f].push_back(st.region[static_cast<size_t>(t)]);
    }
  for (Eigen::Index f = 0; f < n.F.rows(); ++f) {
    std::array<int, 3> k{n.F(f, 0), n.F(f, 1), n.F(f, 2)};
    std::sort(k.begin(), k.end());
    std::vector<int32_t> r = regions.at(k);
    std::sort(r.begin(), r.end());
    if (n.surface[static_cast<size_t>(f)] == 0)
      EXPECT_EQ(r, std::vector<int32_t>{0});
    else
      EXPECT_EQ(r, (std::vector<int32_t>{0, 1}));
  }
}

TEST(TetrahedralizeShells, CrossingSurfacesAreRefusedWithAMessage) {
  // The "inner" surface pokes out of the outer one: no conforming mesh exists.
  const Nested n =
      nested(test::octahedron(4.0), test::octahedron(3.0, Eigen::RowVector3d(2.5, 0, 0)));
  try {
    geometry::tetrahedralize_shells(n.V, n.F, n.surface);
    FAIL() << "crossing surfaces were meshed";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("tetrahedral meshing of the layers failed"),
              std::string::npos)
        << e.what();
  }
}

TEST(MeasureTets, RegularTetrahedronAndAnInvertedOne) {
  Eigen::MatrixX3d X(4, 3);
  X << 1, 1, 1, 1, -1, -1, -1, 1, -1, -1, -1, 1;
  Eigen::MatrixX4i T(2, 4);
  T << 0, 1, 2, 3, 0, 2, 1, 3;
  // Orient the first positively.
  const double v = (X.row(1) - X.row(0)).cross(X.row(2) - X.row(0)).dot(X.row(3) - X.row(0));
  if (v < 0) T.row(0) << 0, 2, 1, 3, T.row(1) << 0, 1, 2, 3;
  const geometry::TetQuality q = geometry::measure_tets(X, T.topRows(1));
  EXPECT_NEAR(q.min_dihedral_deg, std::acos(1.0 / 3.0) * 180.0 / M_PI, 1e-9);  // 70.53 degrees
  EXPECT_NEAR(q.max_dihedral_deg, q.min_dihedral_deg, 1e-9);
  EXPECT_EQ(q.inverted, 0);
  EXPECT_EQ(q.slivers, 0);
  EXPECT_EQ(geometry::measure_tets(X, T).inverted, 1);
}

}  // namespace
