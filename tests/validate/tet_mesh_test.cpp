#include "lamina/validate/tet_mesh.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <string>

#include "lamina/core/error.h"
#include "lamina/geometry/mesh_measures.h"
#include "lamina/validate/fem.h"

namespace {

using namespace lamina;
using namespace lamina::validate;

constexpr double kRadius = 20.0;  // mm

// A voxel ball: voxels whose physical centre lies within kRadius of the grid's physical middle.
Mask sphere_mask(const std::array<double, 3>& spacing, const Eigen::Matrix3d& D,
                 const std::array<double, 3>& origin) {
  Mask m;
  for (int a = 0; a < 3; ++a)
    m.frame.size[a] = static_cast<int64_t>(std::ceil(2 * kRadius / spacing[a])) + 6;
  m.frame.spacing_mm = spacing;
  m.frame.origin_mm = origin;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m.frame.direction[3 * r + c] = D(r, c);
  const auto c = m.frame.to_physical(0.5 * (m.frame.size[0] - 1), 0.5 * (m.frame.size[1] - 1),
                                     0.5 * (m.frame.size[2] - 1));
  m.inside.assign(static_cast<size_t>(m.frame.voxel_count()), 0);
  for (int64_t k = 0; k < m.frame.size[2]; ++k)
    for (int64_t j = 0; j < m.frame.size[1]; ++j)
      for (int64_t i = 0; i < m.frame.size[0]; ++i) {
        const auto p = m.frame.to_physical(i, j, k);
        if (std::hypot(p[0] - c[0], p[1] - c[1], p[2] - c[2]) <= kRadius)
          m.inside[m.frame.index(i, j, k)] = 1;
      }
  return m;
}

// Physical bounding box of the inside voxels, each taken as its full box (centre +- half a
// voxel along every index axis).
Eigen::AlignedBox3d voxel_box(const Mask& m) {
  Eigen::AlignedBox3d box;
  for (int64_t k = 0; k < m.frame.size[2]; ++k)
    for (int64_t j = 0; j < m.frame.size[1]; ++j)
      for (int64_t i = 0; i < m.frame.size[0]; ++i) {
        if (!m.inside[m.frame.index(i, j, k)]) continue;
        for (int corner = 0; corner < 8; ++corner) {
          const double di = (corner & 1) ? 0.5 : -0.5, dj = (corner & 2) ? 0.5 : -0.5,
                       dk = (corner & 4) ? 0.5 : -0.5;
          const auto p = m.frame.to_physical(i + di, j + dj, k + dk);
          box.extend(Eigen::Vector3d(p[0], p[1], p[2]));
        }
      }
  return box;
}

double tet_volume6(const TetMesh& m, Eigen::Index t) {
  const Eigen::Vector3d a = m.V.row(m.T(t, 0)), b = m.V.row(m.T(t, 1)), c = m.V.row(m.T(t, 2)),
                        d = m.V.row(m.T(t, 3));
  return (b - a).dot((c - a).cross(d - a));
}

// Smallest dihedral angle over all tets, degrees: slivers (near 0) spoil a stiffness matrix.
double min_dihedral_deg(const TetMesh& m) {
  double smallest = 180.0;
  for (Eigen::Index t = 0; t < m.T.rows(); ++t)
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) {
        int c = 0;
        while (c == a || c == b) ++c;
        const int d = 6 - a - b - c;
        const Eigen::Vector3d pa = m.V.row(m.T(t, a)), pb = m.V.row(m.T(t, b));
        const Eigen::Vector3d e = (pb - pa).normalized();
        Eigen::Vector3d u = Eigen::Vector3d(m.V.row(m.T(t, c))) - pa;
        Eigen::Vector3d v = Eigen::Vector3d(m.V.row(m.T(t, d))) - pa;
        u -= u.dot(e) * e;
        v -= v.dot(e) * e;
        const double cosine = std::clamp(u.normalized().dot(v.normalized()), -1.0, 1.0);
        smallest = std::min(smallest, std::acos(cosine) * 180.0 / M_PI);
      }
  return smallest;
}

// The invariants every mesh of the ball must hold.
void check_ball_mesh(const Mask& mask, const TetMesh& mesh) {
  ASSERT_GT(mesh.T.rows(), 100);
  // Every vertex is used, every tet positively oriented.
  std::vector<char> used(static_cast<size_t>(mesh.V.rows()), 0);
  for (Eigen::Index t = 0; t < mesh.T.rows(); ++t) {
    ASSERT_GT(tet_volume6(mesh, t), 0.0) << "tet " << t;
    for (int a = 0; a < 4; ++a) used[mesh.T(t, a)] = 1;
  }
  EXPECT_EQ(std::count(used.begin(), used.end(), 0), 0);
  EXPECT_GT(min_dihedral_deg(mesh), 5.0);  // perturbation and exudation removed the slivers

  const double exact = 4.0 / 3.0 * M_PI * std::pow(kRadius, 3);
  const double volume = tet_volume(mesh, mesh.V);
  EXPECT_NEAR(volume / exact, 1.0, 0.03);

  // The boundary is a closed 2-manifold: every edge in exactly two faces, wound oppositely;
  // outward, so it encloses the tets' volume; one piece.
  const Eigen::MatrixX3i F = boundary_faces(mesh);
  std::map<std::pair<int, int>, int> directed;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int e = 0; e < 3; ++e) ++directed[{F(f, e), F(f, (e + 1) % 3)}];
  for (const auto& [edge, count] : directed) {
    ASSERT_EQ(count, 1) << "edge " << edge.first << "-" << edge.second << " used twice one way";
    ASSERT_EQ(directed.count({edge.second, edge.first}), 1u)
        << "edge " << edge.first << "-" << edge.second << " is a border or non-manifold";
  }
  const auto q = geometry::measure_mesh(SurfaceMesh{mesh.V, F});
  EXPECT_TRUE(q.closed);
  EXPECT_TRUE(q.manifold);
  EXPECT_EQ(q.components, 1);
  EXPECT_NEAR(geometry::enclosed_volume(SurfaceMesh{mesh.V, F}), volume, 1e-9 * volume);

  // Physical space: inside the mask's voxels (CGAL's surface search tolerance aside).
  const Eigen::AlignedBox3d box = voxel_box(mask);
  const double tol = 1e-3;
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v) {
    const Eigen::Vector3d p = mesh.V.row(v);
    ASSERT_TRUE((p.array() >= box.min().array() - tol).all() &&
                (p.array() <= box.max().array() + tol).all())
        << "vertex " << v << " at " << p.transpose() << " outside " << box.min().transpose()
        << " .. " << box.max().transpose();
  }
  // ...and filling them: the mesh reaches near every side of the box.
  Eigen::AlignedBox3d mesh_box;
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v) mesh_box.extend(Eigen::Vector3d(mesh.V.row(v)));
  EXPECT_LT((mesh_box.min() - box.min()).cwiseAbs().maxCoeff(), 1.5);
  EXPECT_LT((mesh_box.max() - box.max()).cwiseAbs().maxCoeff(), 1.5);
}

TetMesh timed_mesh(const Mask& mask, const char* what) {
  const auto t0 = std::chrono::steady_clock::now();
  TetMesh mesh = mesh_mask_tets(mask, {});
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ::testing::Test::RecordProperty(std::string(what) + "_tets", std::to_string(mesh.T.rows()));
  ::testing::Test::RecordProperty(std::string(what) + "_seconds", std::to_string(s));
  return mesh;
}

TEST(MeshMaskTets, VoxelBallIsAClosedPositiveMeshOfTheRightVolume) {
  const Mask mask = sphere_mask({1.0, 1.0, 1.0}, Eigen::Matrix3d::Identity(), {-12.0, 30.0, 7.5});
  const TetMesh mesh = timed_mesh(mask, "ball_1mm");
  check_ball_mesh(mask, mesh);
  const TetMesh again = mesh_mask_tets(mask, {});
  ASSERT_EQ(again.V.rows(), mesh.V.rows());
  ASSERT_EQ(again.T.rows(), mesh.T.rows());
  EXPECT_TRUE(again.V == mesh.V);  // bit for bit
  EXPECT_TRUE(again.T == mesh.T);
}

TEST(MeshMaskTets, AnisotropicRotatedGridMeshesInPhysicalSpace) {
  // Index axis i runs along physical +y, j along -x, k along +z (a 90 degree turn about z).
  Eigen::Matrix3d D;
  D << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  const Mask mask = sphere_mask({0.8, 0.8, 2.0}, D, {40.0, -25.0, 110.0});
  const TetMesh mesh = timed_mesh(mask, "ball_anisotropic_rotated");
  check_ball_mesh(mask, mesh);
  const TetMesh again = mesh_mask_tets(mask, {});
  EXPECT_TRUE(again.V == mesh.V);
  EXPECT_TRUE(again.T == mesh.T);

  // A reflecting direction (determinant -1, as a RAS-stored grid read as LPS would give) still
  // gives positive tets.
  Eigen::Matrix3d flip = D;
  flip.col(2) *= -1.0;
  const Mask mirrored = sphere_mask({0.8, 0.8, 2.0}, flip, {40.0, -25.0, 110.0});
  check_ball_mesh(mirrored, mesh_mask_tets(mirrored, {}));
}

TEST(MeshMaskTets, SphereMeshCarriesAnFemSolve) {
  const Mask mask = sphere_mask({1.0, 1.0, 1.0}, Eigen::Matrix3d::Identity(), {0.0, 0.0, 0.0});
  const TetMesh mesh = mesh_mask_tets(mask, {.cell_size_mm = 4.0});  // coarse: a quick test
  // Squeeze the ball between its bottom and top caps by 4 mm (10% of the diameter).
  const double zmin = mesh.V.col(2).minCoeff(), zmax = mesh.V.col(2).maxCoeff();
  FemBoundary b;
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v) {
    if (mesh.V(v, 2) < zmin + 2.0) b.fixed.push_back(static_cast<int32_t>(v));
    if (mesh.V(v, 2) > zmax - 2.0) b.driven.push_back(static_cast<int32_t>(v));
  }
  b.driven_displacement_mm = Eigen::MatrixX3d::Zero(static_cast<Eigen::Index>(b.driven.size()), 3);
  b.driven_displacement_mm.col(2).setConstant(-4.0);
  const FemMaterial mat{.young_modulus_kpa = 5.0, .poisson_ratio = 0.45};
  auto t0 = std::chrono::steady_clock::now();
  const FemResult lin = solve_linear(mesh, mat, b);
  auto t1 = std::chrono::steady_clock::now();
  const FemResult cor = solve_corotational(mesh, mat, b, {});
  auto t2 = std::chrono::steady_clock::now();
  RecordProperty("tets", std::to_string(mesh.T.rows()));
  RecordProperty("linear_seconds", std::to_string(std::chrono::duration<double>(t1 - t0).count()));
  RecordProperty("corotational_seconds",
                 std::to_string(std::chrono::duration<double>(t2 - t1).count()));
  RecordProperty("corotational_solves", cor.iterations);
  ASSERT_TRUE(lin.converged);
  ASSERT_TRUE(cor.converged) << cor.residual;
  // The ball bulges sideways and the two caps carry equal and opposite loads.
  const double push = cor.reaction_mn.col(2).cwiseMin(0.0).sum();
  const double hold = cor.reaction_mn.col(2).cwiseMax(0.0).sum();
  EXPECT_LT(push, 0.0);
  EXPECT_NEAR(hold, -push, 1e-6 * hold);
  const double r0 = mesh.V.leftCols<2>().rowwise().norm().maxCoeff();
  const double r1 = (mesh.V + cor.u).leftCols<2>().rowwise().norm().maxCoeff();
  EXPECT_GT(r1, r0);
  // At 10% strain the two models agree to first order.
  EXPECT_LT((cor.u - lin.u).cwiseAbs().maxCoeff(), 0.3 * lin.u.cwiseAbs().maxCoeff());
}

TEST(MeshMaskTets, EmptyMaskAndBadOptionsThrow) {
  Mask mask;
  mask.frame.size = {8, 8, 8};
  mask.inside.assign(512, 0);
  try {
    mesh_mask_tets(mask, {});
    ADD_FAILURE() << "no error for an empty mask";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::kInvalidInput);
    EXPECT_NE(std::string(e.what()).find("empty"), std::string::npos) << e.what();
  }
  mask.inside[mask.frame.index(4, 4, 4)] = 1;
  EXPECT_THROW(mesh_mask_tets(mask, {.cell_size_mm = -1.0}), Error);
  mask.inside.resize(100);
  EXPECT_THROW(mesh_mask_tets(mask, {}), Error);
}

TEST(BoundaryFaces, TwoTetsShareAFaceThatIsNotBoundary) {
  TetMesh m;
  m.V.resize(5, 3);
  m.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1;
  m.T.resize(2, 4);
  m.T << 0, 1, 2, 3, 0, 2, 1, 4;
  ASSERT_GT(tet_volume6(m, 0), 0.0);
  ASSERT_GT(tet_volume6(m, 1), 0.0);
  EXPECT_NEAR(tet_volume(m, m.V), 2.0 / 6.0, 1e-15);
  const Eigen::MatrixX3i F = boundary_faces(m);
  ASSERT_EQ(F.rows(), 6);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    std::array<int, 3> key{F(f, 0), F(f, 1), F(f, 2)};
    std::sort(key.begin(), key.end());
    EXPECT_FALSE((key == std::array<int, 3>{0, 1, 2})) << "the shared face is not boundary";
  }
  // Outward: the divergence theorem gives back the tets' volume, and a deformed copy too.
  EXPECT_NEAR(geometry::enclosed_volume(SurfaceMesh{m.V, F}), 2.0 / 6.0, 1e-15);
  const Eigen::MatrixX3d x = 2.0 * m.V;
  EXPECT_NEAR(tet_volume(m, x), 8 * 2.0 / 6.0, 1e-14);
  EXPECT_THROW(tet_volume(m, m.V.topRows(3)), Error);
}

}  // namespace
