#include "lamina/validate/fem.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <functional>
#include <string>

#include "lamina/core/error.h"

namespace {

using namespace lamina;
using namespace lamina::validate;

// A box [0, size] split into cells x cells x cells hexahedra, each cut into six tets around its
// main diagonal (Kuhn's subdivision: conforming, no alternation needed).
TetMesh make_block(const Eigen::Vector3d& size, const Eigen::Vector3i& cells) {
  const Eigen::Vector3i n = cells.array() + 1;
  auto node = [&](int i, int j, int k) { return i + n.x() * (j + n.y() * k); };
  TetMesh m;
  m.V.resize(n.prod(), 3);
  for (int k = 0; k < n.z(); ++k)
    for (int j = 0; j < n.y(); ++j)
      for (int i = 0; i < n.x(); ++i)
        m.V.row(node(i, j, k)) =
            Eigen::Vector3d(i, j, k).cwiseProduct(size).cwiseQuotient(cells.cast<double>());
  m.T.resize(6 * cells.prod(), 4);
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  int t = 0;
  for (int k = 0; k < cells.z(); ++k)
    for (int j = 0; j < cells.y(); ++j)
      for (int i = 0; i < cells.x(); ++i)
        for (const auto& p : perms) {
          Eigen::Vector3i c(i, j, k);
          Eigen::Vector4i tet;
          tet[0] = node(c.x(), c.y(), c.z());
          for (int s = 0; s < 3; ++s) {
            c[p[s]] += 1;
            tet[s + 1] = node(c.x(), c.y(), c.z());
          }
          const Eigen::Vector3d a = m.V.row(tet[0]), b = m.V.row(tet[1]), d = m.V.row(tet[2]),
                                e = m.V.row(tet[3]);
          if ((b - a).dot((d - a).cross(e - a)) < 0) std::swap(tet[2], tet[3]);
          m.T.row(t++) = tet;
        }
  return m;
}

std::vector<int32_t> nodes_where(const TetMesh& m,
                                 const std::function<bool(const Eigen::Vector3d&)>& f) {
  std::vector<int32_t> out;
  for (Eigen::Index v = 0; v < m.V.rows(); ++v)
    if (f(m.V.row(v).transpose())) out.push_back(static_cast<int32_t>(v));
  return out;
}

// Uniaxial load along x on a block [0,L]x[0,W]x[0,H]: the face x = 0 slides on a frictionless
// wall (x held), the face x = L is pushed or pulled along x by `stretch * L` and may slide too.
// Rigid motions left over are removed with the least support that does not resist the lateral
// contraction: the origin corner held in x, y, z, and the corner (0, W, 0) held in x and z.
// The exact solution is then homogeneous: u = (e x, -nu e y, -nu e z) for the linear model.
FemBoundary uniaxial(const TetMesh& m, const Eigen::Vector3d& size, double stretch) {
  FemBoundary b;
  const double eps = 1e-9;
  std::vector<std::array<bool, 3>> mask;
  std::vector<Eigen::RowVector3d> disp;
  for (Eigen::Index v = 0; v < m.V.rows(); ++v) {
    const Eigen::Vector3d p = m.V.row(v);
    const bool near = p.x()<eps, far = p.x()> size.x() - eps;
    if (near && p.y() < eps && p.z() < eps) {
      b.fixed.push_back(static_cast<int32_t>(v));
      continue;
    }
    if (!near && !far) continue;
    b.driven.push_back(static_cast<int32_t>(v));
    const bool corner_b = near && p.y() > size.y() - eps && p.z() < eps;
    mask.push_back({true, false, corner_b});
    disp.emplace_back(far ? stretch * size.x() : 0.0, 0.0, 0.0);
  }
  b.driven_displacement_mm.resize(static_cast<Eigen::Index>(disp.size()), 3);
  b.driven_mask.resize(static_cast<Eigen::Index>(mask.size()), 3);
  for (size_t k = 0; k < disp.size(); ++k) {
    b.driven_displacement_mm.row(static_cast<Eigen::Index>(k)) = disp[k];
    for (int c = 0; c < 3; ++c) b.driven_mask(static_cast<Eigen::Index>(k), c) = mask[k][c];
  }
  return b;
}

double sum_reaction_x(const TetMesh& m, const FemResult& r, double x) {
  double sum = 0.0;
  for (Eigen::Index v = 0; v < m.V.rows(); ++v)
    if (std::abs(m.V(v, 0) - x) < 1e-9) sum += r.reaction_mn(v, 0);
  return sum;
}

const Eigen::Vector3d kSize(10.0, 4.0, 3.0);  // mm
const Eigen::Vector3i kCells(5, 2, 2);
const FemMaterial kSoft{.young_modulus_kpa = 5.0, .poisson_ratio = 0.3};

TEST(FemLinear, UniaxialStretchIsTheExactHomogeneousSolution) {
  const TetMesh m = make_block(kSize, kCells);
  const double e = 0.01;
  const FemResult r = solve_linear(m, kSoft, uniaxial(m, kSize, e));
  ASSERT_TRUE(r.converged);
  EXPECT_LT(r.residual, 1e-10);
  const double nu = kSoft.poisson_ratio;
  for (Eigen::Index v = 0; v < m.V.rows(); ++v) {
    const Eigen::RowVector3d X = m.V.row(v);
    const Eigen::RowVector3d exact(e * X.x(), -nu * e * X.y(), -nu * e * X.z());
    ASSERT_LT((r.u.row(v) - exact).norm(), 1e-6 * e * kSize.x()) << "node " << v;
  }
  // Lateral contraction = nu x axial strain, measured on the far corner.
  const Eigen::Index corner = m.V.rows() - 1;
  EXPECT_NEAR(-r.u(corner, 1) / kSize.y(), nu * e, 1e-6 * nu * e);
  // The pulled face needs E A e, the wall pushes back with as much, and nothing else is loaded.
  const double force = kSoft.young_modulus_kpa * kSize.y() * kSize.z() * e;
  EXPECT_NEAR(sum_reaction_x(m, r, kSize.x()), force, 1e-6 * force);
  EXPECT_NEAR(sum_reaction_x(m, r, 0.0), -force, 1e-6 * force);
  EXPECT_LT(r.reaction_mn.rightCols<2>().cwiseAbs().maxCoeff(), 1e-9 * force);
  const double V0 = kSize.prod();
  EXPECT_NEAR(r.volume_mm3, V0 * (1 + e) * (1 - nu * e) * (1 - nu * e), 1e-9 * V0);
}

TEST(FemLinear, NodalForcesBalanceTheReactions) {
  // A cantilever clamped at x = 0 and loaded at its free end: the support carries the load.
  const TetMesh m = make_block(kSize, kCells);
  FemBoundary b;
  b.fixed = nodes_where(m, [](const Eigen::Vector3d& p) { return p.x() < 1e-9; });
  b.nodal_force_mn = Eigen::MatrixX3d::Zero(m.V.rows(), 3);
  const auto tip =
      nodes_where(m, [](const Eigen::Vector3d& p) { return p.x() > kSize.x() - 1e-9; });
  for (int32_t v : tip) b.nodal_force_mn(v, 2) = -0.01;
  const FemResult r = solve_linear(m, kSoft, b);
  ASSERT_TRUE(r.converged);
  const Eigen::RowVector3d total_load = b.nodal_force_mn.colwise().sum();
  const Eigen::RowVector3d total_reaction = r.reaction_mn.colwise().sum();
  EXPECT_LT((total_load + total_reaction).norm(), 1e-9 * total_load.norm());
  for (int32_t v : tip) EXPECT_LT(r.u(v, 2), 0.0);
  for (int32_t v : b.fixed) EXPECT_EQ(r.u.row(v).norm(), 0.0);
}

TEST(FemCorotational, EqualsLinearForATinyStrain) {
  const TetMesh m = make_block(kSize, kCells);
  // A cantilever bent by a tiny tip displacement (rotations ~1e-4), and a tiny uniaxial stretch.
  FemBoundary bend;
  bend.fixed = nodes_where(m, [](const Eigen::Vector3d& p) { return p.x() < 1e-9; });
  bend.driven = nodes_where(m, [](const Eigen::Vector3d& p) { return p.x() > kSize.x() - 1e-9; });
  bend.driven_displacement_mm = Eigen::MatrixX3d::Zero(bend.driven.size(), 3);
  bend.driven_displacement_mm.col(2).setConstant(1e-4 * kSize.x());
  for (const FemBoundary& b : {bend, uniaxial(m, kSize, 1e-4)}) {
    const FemResult lin = solve_linear(m, kSoft, b);
    const FemResult cor = solve_corotational(m, kSoft, b, {});
    ASSERT_TRUE(lin.converged);
    ASSERT_TRUE(cor.converged);
    EXPECT_LT(cor.residual, 1e-8);
    const double u_scale = lin.u.cwiseAbs().maxCoeff();
    const double f_scale = lin.reaction_mn.cwiseAbs().maxCoeff();
    ASSERT_GT(u_scale, 0.0);
    ASSERT_GT(f_scale, 0.0);
    EXPECT_LT((cor.u - lin.u).cwiseAbs().maxCoeff(), 1e-3 * u_scale);
    EXPECT_LT((cor.reaction_mn - lin.reaction_mn).cwiseAbs().maxCoeff(), 1e-3 * f_scale);
  }
}

TEST(FemCorotational, RigidRotationCostsNoForceWhileLinearResists) {
  const TetMesh m = make_block(kSize, kCells);
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(60.0 * M_PI / 180.0, Eigen::Vector3d(1, 1, 1).normalized())
          .toRotationMatrix();
  const Eigen::RowVector3d c = 0.5 * kSize.transpose();
  auto rotated = [&](Eigen::Index v) -> Eigen::RowVector3d {
    return (m.V.row(v) - c) * R.transpose() + c - m.V.row(v);
  };
  // A scale for nodal forces: E times the area of one cell face (strain ~1 on every element).
  const double cell_force =
      kSoft.young_modulus_kpa * (kSize.y() / kCells.y()) * (kSize.z() / kCells.z());

  // Every node driven by the rotation.
  FemBoundary all;
  for (Eigen::Index v = 0; v < m.V.rows(); ++v) all.driven.push_back(static_cast<int32_t>(v));
  all.driven_displacement_mm.resize(m.V.rows(), 3);
  for (Eigen::Index v = 0; v < m.V.rows(); ++v) all.driven_displacement_mm.row(v) = rotated(v);
  const FemResult lin = solve_linear(m, kSoft, all);
  const FemResult cor = solve_corotational(m, kSoft, all, {});
  ASSERT_TRUE(cor.converged);
  const double lin_max = lin.reaction_mn.rowwise().norm().maxCoeff();
  const double cor_max = cor.reaction_mn.rowwise().norm().maxCoeff();
  EXPECT_GT(lin_max, 0.05 * cell_force);  // the spurious stress of a rotation seen as strain
  EXPECT_LT(cor_max, 1e-9 * cell_force);
  EXPECT_NEAR(cor.volume_mm3, kSize.prod(), 1e-9 * kSize.prod());
  RecordProperty("linear_max_reaction_mn", std::to_string(lin_max));
  RecordProperty("corotational_max_reaction_mn", std::to_string(cor_max));

  // Only the two end faces driven: the solve must find the rotation for the free interior.
  FemBoundary ends;
  ends.driven = nodes_where(
      m, [](const Eigen::Vector3d& p) { return p.x() < 1e-9 || p.x() > kSize.x() - 1e-9; });
  ends.driven_displacement_mm.resize(static_cast<Eigen::Index>(ends.driven.size()), 3);
  for (size_t k = 0; k < ends.driven.size(); ++k)
    ends.driven_displacement_mm.row(static_cast<Eigen::Index>(k)) = rotated(ends.driven[k]);
  const FemResult cor_ends = solve_corotational(m, kSoft, ends, {});
  const FemResult lin_ends = solve_linear(m, kSoft, ends);
  ASSERT_TRUE(cor_ends.converged);
  for (Eigen::Index v = 0; v < m.V.rows(); ++v)
    ASSERT_LT((cor_ends.u.row(v) - rotated(v)).norm(), 1e-6 * kSize.x()) << "node " << v;
  EXPECT_LT(cor_ends.reaction_mn.rowwise().norm().maxCoeff(), 1e-6 * cell_force);
  EXPECT_GT(lin_ends.reaction_mn.rowwise().norm().maxCoeff(), 0.05 * cell_force);
}

TEST(FemCorotational, LargeCompressionKeepsVolumeAsNuSays) {
  const TetMesh m = make_block(kSize, kCells);
  const double V0 = kSize.prod();
  for (double nu : {0.0, 0.3, 0.49}) {
    // Frictionless platens: the homogeneous answer is exact, lateral stretch 1 + 0.2 nu (the
    // material is Hookean in the rotated frame), volume 0.8 (1 + 0.2 nu)^2.
    const FemMaterial mat{.young_modulus_kpa = 5.0, .poisson_ratio = nu};
    const FemResult r = solve_corotational(m, mat, uniaxial(m, kSize, -0.2), {});
    ASSERT_TRUE(r.converged) << "nu " << nu << " residual " << r.residual;
    const double lateral = 1.0 + 0.2 * nu;
    const Eigen::Index corner = m.V.rows() - 1;
    EXPECT_NEAR((kSize.y() + r.u(corner, 1)) / kSize.y(), lateral, 1e-6) << "nu " << nu;
    EXPECT_NEAR(r.volume_mm3 / V0, 0.8 * lateral * lateral, 1e-6) << "nu " << nu;
  }
  // Bonded platens (both end faces clamped): the block barrels, the answer is no longer
  // homogeneous, and how much volume it keeps is still set by nu.
  FemBoundary clamp;
  clamp.fixed = nodes_where(m, [](const Eigen::Vector3d& p) { return p.x() < 1e-9; });
  clamp.driven = nodes_where(m, [](const Eigen::Vector3d& p) { return p.x() > kSize.x() - 1e-9; });
  clamp.driven_displacement_mm = Eigen::MatrixX3d::Zero(clamp.driven.size(), 3);
  clamp.driven_displacement_mm.col(0).setConstant(-0.2 * kSize.x());
  const FemResult soft =
      solve_corotational(m, {.young_modulus_kpa = 5.0, .poisson_ratio = 0.49}, clamp, {});
  const FemResult comp =
      solve_corotational(m, {.young_modulus_kpa = 5.0, .poisson_ratio = 0.0}, clamp, {});
  ASSERT_TRUE(soft.converged) << soft.residual;
  ASSERT_TRUE(comp.converged) << comp.residual;
  // The material is Hookean in the element's frame: it holds the trace of the (Biot) strain, not
  // det F, so at 20% strain the volume drifts by second-order terms even as nu -> 0.5 (3.5% in
  // the homogeneous case above).
  EXPECT_LT(std::abs(soft.volume_mm3 / V0 - 1.0), 0.07);
  EXPECT_GT(std::abs(comp.volume_mm3 / V0 - 1.0), 0.15);
  RecordProperty("volume_change_nu_0_49", std::to_string(soft.volume_mm3 / V0 - 1));
  RecordProperty("volume_change_nu_0", std::to_string(comp.volume_mm3 / V0 - 1));
}

TEST(FemNeoHookean, UniaxialStretchAndCompressionAreTheHomogeneousSolution) {
  // Frictionless platens: F = diag(s, t, t) exactly. Stable Neo-Hookean's lateral stress
  // mu t + p s t vanishes for the pressure p = lambda' (s t^2 - alpha) = -mu / s, so
  // t^2 = (alpha - mu / (lambda' s)) / s, and the nominal axial stress is mu (s - t^2 / s).
  // (Squeezed by 20% this slender block buckles sideways instead.)
  const TetMesh m = make_block(kSize, kCells);
  const double V0 = kSize.prod();
  for (double nu : {0.3, 0.49})
    for (double e : {-0.1, 0.3, 0.6}) {
      const FemMaterial mat{.young_modulus_kpa = 5.0, .poisson_ratio = nu};
      const double E = mat.young_modulus_kpa;
      const double mu = E / (2 * (1 + nu)), lambda = E * nu / ((1 + nu) * (1 - 2 * nu)) + mu;
      const double alpha = 1 + mu / lambda, s = 1 + e;
      const double t = std::sqrt((alpha - mu / (lambda * s)) / s);
      // The options lamina validate solves with.
      const FemResult r = solve_neo_hookean(m, mat, uniaxial(m, kSize, e),
                                            {.load_steps = 20, .max_newton_iterations = 50});
      ASSERT_TRUE(r.converged) << "nu " << nu << " e " << e << " residual " << r.residual;
      const Eigen::Index corner = m.V.rows() - 1;
      EXPECT_NEAR((kSize.y() + r.u(corner, 1)) / kSize.y(), t, 1e-6) << "nu " << nu << " e " << e;
      EXPECT_NEAR(r.volume_mm3 / V0, s * t * t, 1e-6) << "nu " << nu << " e " << e;
      const double force = mu * (s - t * t / s) * kSize.y() * kSize.z();
      EXPECT_NEAR(sum_reaction_x(m, r, kSize.x()), force, 1e-6 * std::abs(force))
          << "nu " << nu << " e " << e;
    }
  // A tiny strain: linear elasticity.
  const FemResult lin = solve_linear(m, kSoft, uniaxial(m, kSize, 1e-4));
  const FemResult neo = solve_neo_hookean(m, kSoft, uniaxial(m, kSize, 1e-4), {});
  ASSERT_TRUE(neo.converged);
  EXPECT_LT((neo.u - lin.u).cwiseAbs().maxCoeff(), 1e-3 * lin.u.cwiseAbs().maxCoeff());
}

// A block on a fixed floor pressed from above by the sphere tool's law: the solve converges,
// the floor holds exactly the sphere's push, the push points into the block and grows with
// depth, and a sphere pressed to the same depth on the block's middle meets no shear.
TEST(FemSphere, PressedBlockConvergesAndTheFloorHoldsTheSpheresPush) {
  const Eigen::Vector3d size(40.0, 40.0, 20.0);
  const TetMesh m = make_block(size, Eigen::Vector3i(10, 10, 5));
  FemBoundary b;
  b.fixed = nodes_where(m, [](const Eigen::Vector3d& p) { return p.z() < 1e-9; });
  b.driven_displacement_mm.resize(0, 3);
  const double r = 8.0;
  b.sphere_start_mm = Eigen::Vector3d(20.0, 20.0, size.z() + r);  // touching the top
  double last = 0.0;
  for (FemLaw law : {FemLaw::kCorotational, FemLaw::kNeoHookean})
    for (double depth : {1.0, 3.0}) {
      SCOPED_TRACE(::testing::Message()
                   << "depth " << depth << (law == FemLaw::kNeoHookean ? " NH" : " corotational"));
      b.sphere = lamina::interact::PressingSphere{
          .center_mm = b.sphere_start_mm - Eigen::Vector3d(0, 0, depth),
          .radius_mm = r,
          .stiffness_kpa_per_mm = 2.0};
      const FemResult res = law == FemLaw::kNeoHookean ? solve_neo_hookean(m, kSoft, b, {})
                                                       : solve_corotational(m, kSoft, b, {});
      EXPECT_TRUE(res.converged) << "residual " << res.residual << " after " << res.iterations;
      const Eigen::Vector3d push = res.sphere_push_mn;
      EXPECT_LT(push.z(), 0.0) << "down into the block";
      EXPECT_LT(push.head<2>().norm(), 0.02 * push.norm());
      Eigen::Vector3d held = Eigen::Vector3d::Zero();
      for (int32_t v : b.fixed) held += res.reaction_mn.row(v).transpose();
      EXPECT_LT((held + push).norm(), 1e-5 * push.norm()) << "the floor holds the push";
      // The top under the sphere sinks, by less than the sphere travelled (a penalty).
      const Eigen::Index top =
          static_cast<Eigen::Index>(nodes_where(m, [&](const Eigen::Vector3d& p) {
            return (p - Eigen::Vector3d(20.0, 20.0, size.z())).norm() < 1e-9;
          })[0]);
      EXPECT_LT(res.u(top, 2), 0.0);
      EXPECT_GT(res.u(top, 2), -depth);
      if (depth > 1.0) EXPECT_GT(-push.z(), 2.0 * last);
      last = -push.z();
    }
  EXPECT_THROW(solve_linear(m, kSoft, b), Error);
  b.sphere->stiffness_kpa_per_mm = 0.0;
  EXPECT_THROW(solve_corotational(m, kSoft, b, {}), Error);
}

TEST(FemCorotational, ReportsMissedTolerance) {
  // A clamped block squeezed by 30% in one step with one iteration cannot be in balance.
  const TetMesh m = make_block(kSize, kCells);
  FemBoundary b;
  b.fixed = nodes_where(m, [](const Eigen::Vector3d& p) { return p.x() < 1e-9; });
  b.driven = nodes_where(m, [](const Eigen::Vector3d& p) { return p.x() > kSize.x() - 1e-9; });
  b.driven_displacement_mm = Eigen::MatrixX3d::Zero(b.driven.size(), 3);
  b.driven_displacement_mm.col(0).setConstant(-0.3 * kSize.x());
  const FemResult r =
      solve_corotational(m, kSoft, b, {.load_steps = 1, .max_newton_iterations = 1});
  EXPECT_FALSE(r.converged);
  EXPECT_GT(r.residual, 1e-8);
  EXPECT_EQ(r.iterations, 1);
  // Given the iterations, the same problem converges.
  const FemResult done =
      solve_corotational(m, kSoft, b, {.load_steps = 1, .max_newton_iterations = 100});
  EXPECT_TRUE(done.converged) << done.residual;
}

template <typename F>
void expect_invalid(F&& f, const std::string& needle) {
  try {
    f();
    ADD_FAILURE() << "no error; expected one mentioning '" << needle << "'";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::kInvalidInput) << e.what();
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TEST(Fem, InvalidInputsThrowWithAClearMessage) {
  const TetMesh m = make_block(kSize, Eigen::Vector3i(2, 1, 1));
  FemBoundary ok;
  ok.fixed = {0};
  ok.driven = {5};
  ok.driven_displacement_mm = Eigen::MatrixX3d::Constant(1, 3, 0.1);
  auto both = [&](const TetMesh& mesh, const FemMaterial& mat, const FemBoundary& b,
                  const std::string& needle) {
    expect_invalid([&] { solve_linear(mesh, mat, b); }, needle);
    expect_invalid([&] { solve_corotational(mesh, mat, b, {}); }, needle);
  };
  both(m, {.young_modulus_kpa = 0.0, .poisson_ratio = 0.3}, ok, "young_modulus_kpa");
  both(m, {.young_modulus_kpa = -1.0, .poisson_ratio = 0.3}, ok, "young_modulus_kpa");
  both(m, {.young_modulus_kpa = NAN, .poisson_ratio = 0.3}, ok, "young_modulus_kpa");
  both(m, {.young_modulus_kpa = 5.0, .poisson_ratio = 0.5}, ok, "poisson_ratio");
  both(m, {.young_modulus_kpa = 5.0, .poisson_ratio = -1.0}, ok, "poisson_ratio");

  FemBoundary none;
  both(m, kSoft, none, "needs fixed or driven nodes");
  FemBoundary out = ok;
  out.fixed = {static_cast<int32_t>(m.V.rows())};
  both(m, kSoft, out, "out of range");
  out = ok;
  out.driven = {-1};
  both(m, kSoft, out, "out of range");
  FemBoundary twice = ok;
  twice.driven = {0};
  both(m, kSoft, twice, "listed twice");
  FemBoundary nan_disp = ok;
  nan_disp.driven_displacement_mm(0, 1) = NAN;
  both(m, kSoft, nan_disp, "non-finite");
  FemBoundary rows = ok;
  rows.driven_displacement_mm.resize(2, 3);
  rows.driven_displacement_mm.setZero();
  both(m, kSoft, rows, "one row per driven node");
  FemBoundary force = ok;
  force.nodal_force_mn = Eigen::MatrixX3d::Zero(m.V.rows(), 3);
  force.nodal_force_mn(1, 0) = INFINITY;
  both(m, kSoft, force, "non-finite");
  force.nodal_force_mn.resize(3, 3);
  force.nodal_force_mn.setZero();
  both(m, kSoft, force, "#V");

  TetMesh bad = m;
  bad.V(2, 1) = NAN;
  both(bad, kSoft, ok, "non-finite");
  bad = m;
  bad.T(0, 3) = static_cast<int>(m.V.rows());
  both(bad, kSoft, ok, "mesh.T");
  bad = m;
  std::swap(bad.T(1, 2), bad.T(1, 3));  // inverted
  both(bad, kSoft, ok, "inverted");

  expect_invalid([&] { solve_corotational(m, kSoft, ok, {.load_steps = 0}); }, "load_steps");
  expect_invalid([&] { solve_corotational(m, kSoft, ok, {.max_newton_iterations = 0}); },
                 "max_newton_iterations");
  expect_invalid([&] { solve_corotational(m, kSoft, ok, {.tolerance = 0.0}); }, "tolerance");
}

}  // namespace
