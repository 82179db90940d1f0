// Linear and corotational P1 tetrahedra. Both share one kernel: an element's nodal forces are
// f_a = V R sigma(H) g_a, where g_a is the rest gradient of shape function a, H the displacement
// gradient in the element's frame and sigma = lambda tr(H) I + mu (H + H^T) the small-strain
// (Hooke) stress. Linear elasticity is R = I and H = sum_b u_b g_b^T; the corotational model
// takes R from the polar decomposition of the deformation gradient F = I + sum_b u_b g_b^T and
// H = R^T F - I, which is R K_e (R^T x - X) written per node. Written this way, an element
// stores 13 numbers (g and V) instead of a 12x12 matrix, and the rotated stiffness block
// R K_ab R^T = V (lambda h_a h_b^T + mu h_b h_a^T + mu (g_a . g_b) I), with h = R g, costs a
// few dozen flops.
#include "lamina/validate/fem.h"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/interact/sphere_pressure.h"
#include "sparse_factor.h"

namespace lamina::validate {
namespace {

using SpMat = Eigen::SparseMatrix<double>;
using Grad = Eigen::Matrix<double, 4, 3>;  // row a = gradient of shape function a, 1/mm

// solve_linear() reports convergence below this relative residual (a direct factor gives ~1e-14).
constexpr double kLinearTolerance = 1e-8;

bool finite_number(double v) {
  return std::isfinite(v);
}

// A Neo-Hookean element's tangent at the current u: d P / d F over F's nine entries (row-major),
// projected to positive semi-definite (neo_hookean_stress()).
struct NeoState {
  Eigen::Matrix<double, 9, 9> tangent = Eigen::Matrix<double, 9, 9>::Zero();
};

// Everything a solve needs, sized once from the mesh and the boundary.
struct Workspace {
  int nodes = 0;
  double lambda = 0.0, mu = 0.0;  // Lame parameters, kPa
  const Eigen::MatrixX4i* T = nullptr;
  std::vector<Grad, Eigen::aligned_allocator<Grad>> grad;  // per tet
  std::vector<double> rest_volume;                         // per tet, mm^3
  // Per degree of freedom (3 * node + component):
  std::vector<int> free_index;  // index among the unknowns, or -1 (constrained or unused)
  std::vector<char> constrained;
  Eigen::VectorXd target;  // final prescribed displacement of constrained dofs, mm
  Eigen::VectorXd f_ext;   // external force, mN
  int unknowns = 0;

  // Tangent restricted to the unknowns; slot[144 t + 12 (3a+i) + (3b+m)] is the index of the
  // entry (row of node a comp i, column of node b comp m) of tet t in K.valuePtr(), or -1.
  SpMat K;
  std::vector<int> slot;
  SparseFactor factor;
  Eigen::ConjugateGradient<SpMat, Eigen::Lower | Eigen::Upper> cg;
  bool factored = false;     // factor holds a factor of some recent K
  double force_scale = 0.0;  // largest force norm met so far, mN (see relative_residual)

  FemLaw law = FemLaw::kLinear;
  std::vector<Eigen::Matrix3d, Eigen::aligned_allocator<Eigen::Matrix3d>> rotation;  // per tet
  std::vector<NeoState, Eigen::aligned_allocator<NeoState>> neo;  // per tet (Neo-Hookean)
  // The pressing sphere (FemBoundary::sphere): its boundary faces, where its centre is now, the
  // pieces it pressed at the last internal_forces() and the positions they were found at.
  const Eigen::MatrixX3d* V = nullptr;
  std::optional<interact::PressingSphere> sphere;
  Eigen::Vector3d sphere_start = Eigen::Vector3d::Zero(), sphere_end = Eigen::Vector3d::Zero();
  Eigen::MatrixX3i faces;
  std::vector<interact::PressedPiece> pieces;
  Eigen::MatrixX3d x;
  // The tangent includes the turn of each pressed piece's normal (exact, but indefinite where
  // the sphere presses hard): only once Newton is near the answer (solve_nonlinear()).
  bool contact_curvature = false;
  Eigen::MatrixXd element_force;            // 12 by #T, filled in parallel, summed in a fixed order
  Eigen::VectorXd u, u_saved, f_int, work;  // per dof
  Eigen::VectorXd residual, step, rhs, check, cg_r, cg_z, cg_p;  // per unknown
};

void check_inputs(const TetMesh& mesh, const FemMaterial& material, const FemBoundary& b) {
  const double E = material.young_modulus_kpa, nu = material.poisson_ratio;
  if (!finite_number(E) || E <= 0.0)
    throw invalid_input("fem: young_modulus_kpa", fmt::format("must be finite and > 0, got {}", E));
  if (!finite_number(nu) || nu <= -1.0 || nu >= 0.5)
    throw invalid_input("fem: poisson_ratio", fmt::format("must be in (-1, 0.5), got {}", nu));
  const Eigen::Index n = mesh.V.rows();
  if (n == 0 || mesh.T.rows() == 0)
    throw invalid_input("fem: mesh",
                        fmt::format("has {} vertices and {} tets; needs both", n, mesh.T.rows()));
  if (!mesh.V.allFinite()) throw invalid_input("fem: mesh.V", "has a non-finite coordinate");
  if (mesh.T.minCoeff() < 0 || mesh.T.maxCoeff() >= n)
    throw invalid_input("fem: mesh.T", fmt::format("indices must be in [0, {}), found {}..{}", n,
                                                   mesh.T.minCoeff(), mesh.T.maxCoeff()));
  auto check_nodes = [n](const std::vector<int32_t>& list, const char* what) {
    for (int32_t v : list)
      if (v < 0 || v >= n)
        throw invalid_input(fmt::format("fem: boundary.{}", what),
                            fmt::format("node {} is out of range [0, {})", v, n));
  };
  check_nodes(b.fixed, "fixed");
  check_nodes(b.driven, "driven");
  const auto driven = static_cast<Eigen::Index>(b.driven.size());
  if (b.driven_displacement_mm.rows() != driven)
    throw invalid_input("fem: boundary.driven_displacement_mm",
                        fmt::format("needs one row per driven node ({}), got {}", driven,
                                    b.driven_displacement_mm.rows()));
  if (!b.driven_displacement_mm.allFinite())
    throw invalid_input("fem: boundary.driven_displacement_mm", "has a non-finite value");
  if (b.driven_mask.size() != 0 && b.driven_mask.rows() != driven)
    throw invalid_input("fem: boundary.driven_mask",
                        fmt::format("must be empty or have one row per driven node ({}), got {}",
                                    driven, b.driven_mask.rows()));
  if (b.nodal_force_mn.size() != 0 && b.nodal_force_mn.rows() != n)
    throw invalid_input(
        "fem: boundary.nodal_force_mn",
        fmt::format("must be empty or #V ({}) rows, got {}", n, b.nodal_force_mn.rows()));
  if (!b.nodal_force_mn.allFinite())
    throw invalid_input("fem: boundary.nodal_force_mn", "has a non-finite value");
  if (b.sphere) {
    if (const auto problem = interact::sphere_problem(*b.sphere))
      throw invalid_input(fmt::format("fem: boundary.sphere.{}", problem->first), problem->second);
    if (!b.sphere_start_mm.allFinite())
      throw invalid_input("fem: boundary.sphere_start_mm", "is not finite");
  }
}

// Validates, then builds the dof numbering, rest gradients and the sparsity pattern.
void setup(const TetMesh& mesh, const FemMaterial& material, const FemBoundary& b, Workspace& w) {
  check_inputs(mesh, material, b);
  const double E = material.young_modulus_kpa, nu = material.poisson_ratio;
  w.lambda = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
  w.mu = E / (2.0 * (1.0 + nu));
  w.nodes = static_cast<int>(mesh.V.rows());
  w.T = &mesh.T;
  w.V = &mesh.V;
  if (b.sphere) {
    w.sphere = b.sphere;
    w.sphere_start = b.sphere_start_mm;
    w.sphere_end = b.sphere->center_mm;
    w.sphere->center_mm = w.sphere_start;  // load steps move it on
    w.faces = boundary_faces(mesh);
    w.x.resize(mesh.V.rows(), 3);
  }
  const int dofs = 3 * w.nodes;
  const Eigen::Index tets = mesh.T.rows();

  // Constraints. A node may appear in only one list, once.
  std::vector<char> listed(static_cast<size_t>(w.nodes), 0);
  w.constrained.assign(static_cast<size_t>(dofs), 0);
  w.target = Eigen::VectorXd::Zero(dofs);
  auto claim = [&](int32_t v, const char* what) {
    if (listed[v])
      throw invalid_input(
          fmt::format("fem: boundary.{}", what),
          fmt::format("node {} is listed twice (a node is fixed or driven, once)", v));
    listed[v] = 1;
  };
  for (int32_t v : b.fixed) {
    claim(v, "fixed");
    for (int c = 0; c < 3; ++c) w.constrained[3 * v + c] = 1;
  }
  for (size_t k = 0; k < b.driven.size(); ++k) {
    const int32_t v = b.driven[k];
    claim(v, "driven");
    for (int c = 0; c < 3; ++c) {
      if (b.driven_mask.size() != 0 && !b.driven_mask(static_cast<Eigen::Index>(k), c)) continue;
      w.constrained[3 * v + c] = 1;
      w.target[3 * v + c] = b.driven_displacement_mm(static_cast<Eigen::Index>(k), c);
    }
  }
  if (std::find(w.constrained.begin(), w.constrained.end(), 1) == w.constrained.end())
    throw invalid_input("fem: boundary",
                        "needs fixed or driven nodes (with no support the stiffness is singular)");

  w.f_ext = Eigen::VectorXd::Zero(dofs);
  if (b.nodal_force_mn.size() != 0)
    for (int v = 0; v < w.nodes; ++v)
      for (int c = 0; c < 3; ++c) w.f_ext[3 * v + c] = b.nodal_force_mn(v, c);

  // Rest gradients: for a = 1..3, grad N_a is row a-1 of Dm^-1, Dm = [X1-X0, X2-X0, X3-X0];
  // grad N_0 = -(their sum), as the shape functions sum to one.
  std::vector<char> used(static_cast<size_t>(w.nodes), 0);
  w.grad.resize(static_cast<size_t>(tets));
  w.rest_volume.resize(static_cast<size_t>(tets));
  for (Eigen::Index t = 0; t < tets; ++t) {
    Eigen::Matrix3d Dm;
    const Eigen::RowVector3d X0 = mesh.V.row(mesh.T(t, 0));
    for (int a = 1; a < 4; ++a) Dm.col(a - 1) = (mesh.V.row(mesh.T(t, a)) - X0).transpose();
    const double volume = Dm.determinant() / 6.0;
    const double edge = Dm.colwise().norm().maxCoeff();
    // Relative test: a tet flatter than 1e-12 of its edge cube has no usable stiffness.
    if (!(volume > 1e-12 * edge * edge * edge))
      throw invalid_input("fem: mesh.T",
                          fmt::format("tet {} is inverted or flat (volume {:g} mm^3); tets must be "
                                      "positively oriented",
                                      t, volume));
    const Eigen::Matrix3d inv = Dm.inverse();
    Grad& g = w.grad[t];
    g.bottomRows<3>() = inv;
    g.row(0) = -inv.colwise().sum();
    w.rest_volume[t] = volume;
    for (int a = 0; a < 4; ++a) used[mesh.T(t, a)] = 1;
  }

  // Unknowns: unconstrained components of nodes that some tet uses (others have no stiffness).
  w.free_index.assign(static_cast<size_t>(dofs), -1);
  w.unknowns = 0;
  for (int d = 0; d < dofs; ++d) {
    if (w.constrained[d]) continue;
    if (!used[d / 3]) {
      if (w.f_ext[d] != 0.0)
        throw invalid_input("fem: boundary.nodal_force_mn",
                            fmt::format("loads node {}, which no tet uses", d / 3));
      continue;
    }
    w.free_index[d] = w.unknowns++;
  }

  // Sparsity pattern of the unknowns' block, then each element entry's place in it: both walk
  // every (tet, row p, column q) whose row and column are unknowns.
  auto for_each_free_entry = [&](auto&& visit) {
    for (Eigen::Index t = 0; t < tets; ++t)
      for (int p = 0; p < 12; ++p) {
        const int r = w.free_index[3 * mesh.T(t, p / 3) + p % 3];
        if (r < 0) continue;
        for (int q = 0; q < 12; ++q) {
          const int c = w.free_index[3 * mesh.T(t, q / 3) + q % 3];
          if (c >= 0) visit(t, p, q, r, c);
        }
      }
  };
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(static_cast<size_t>(tets) * 144);
  for_each_free_entry(
      [&](Eigen::Index, int, int, int r, int c) { entries.emplace_back(r, c, 0.0); });
  w.K.resize(w.unknowns, w.unknowns);
  w.K.setFromTriplets(entries.begin(), entries.end());
  w.K.makeCompressed();
  w.slot.assign(static_cast<size_t>(tets) * 144, -1);
  const int* outer = w.K.outerIndexPtr();
  const int* inner = w.K.innerIndexPtr();
  for_each_free_entry([&](Eigen::Index t, int p, int q, int r, int c) {
    const int* at = std::lower_bound(inner + outer[c], inner + outer[c + 1], r);
    w.slot[static_cast<size_t>(t) * 144 + 12 * p + q] = static_cast<int>(at - inner);
  });

  w.rotation.assign(static_cast<size_t>(tets), Eigen::Matrix3d::Identity());
  w.element_force.resize(12, tets);
  w.u = Eigen::VectorXd::Zero(dofs);
  w.u_saved.resize(dofs);
  w.f_int.resize(dofs);
  w.work.resize(dofs);
  w.residual.resize(w.unknowns);
  w.step.resize(w.unknowns);
  w.rhs.resize(w.unknowns);
  w.check.resize(w.unknowns);
  w.cg_r.resize(w.unknowns);
  w.cg_z.resize(w.unknowns);
  w.cg_p.resize(w.unknowns);
}

// Rotation of the polar decomposition F = R S, through the SVD F = U Sigma V^T: R = U V^T, with
// the column of the smallest singular value flipped when that would be a reflection (an
// inverted element then gets a proper rotation and a negative stretch, which pushes it back).
Eigen::Matrix3d polar_rotation(const Eigen::Matrix3d& F) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU();
  const Eigen::Matrix3d& V = svd.matrixV();
  if ((U * V.transpose()).determinant() < 0.0) U.col(2) *= -1.0;
  return U * V.transpose();
}

// Displacement gradient sum_b d_b g_b^T of the displacement field d (per dof) over tet t.
Eigen::Matrix3d displacement_gradient(const Workspace& w, Eigen::Index t,
                                      const Eigen::VectorXd& d) {
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (int a = 0; a < 4; ++a) {
    const int v = (*w.T)(t, a);
    H += Eigen::Vector3d(d[3 * v], d[3 * v + 1], d[3 * v + 2]) * w.grad[t].row(a);
  }
  return H;
}

// Sums the per-element forces (12 by #T) into a per-dof vector, in tet order (deterministic).
void gather(const Workspace& w, Eigen::VectorXd& out) {
  out.setZero();
  for (Eigen::Index t = 0; t < w.T->rows(); ++t)
    for (int a = 0; a < 4; ++a)
      out.segment<3>(3 * (*w.T)(t, a)) += w.element_force.col(t).segment<3>(3 * a);
}

// Stable Neo-Hookean (Smith, de Goes & Kim 2018; the simulation's own energy, src/sim/
// neo_hookean_term.cpp, without its inversion guard): P = mu F + lambda' (J - alpha) dJ/dF with
// lambda' = lambda + mu, alpha = 1 + mu / lambda'. Its tangent mu I + lambda' g g^T + p H_J (g =
// dJ/dF, H_J = d^2 J / dF^2) is indefinite where p H_J outweighs mu; a reference solve can
// afford the exact projection (a 9 x 9 eigendecomposition per element, its negative eigenvalues
// set to zero: projected Newton), which the simulation's 1 ms step cannot.
Eigen::Matrix3d neo_hookean_stress(const Workspace& w, const Eigen::Matrix3d& F, NeoState& s) {
  const double lambda = w.lambda + w.mu, alpha = 1.0 + w.mu / lambda;
  Eigen::Matrix3d cof;
  cof.col(0) = F.col(1).cross(F.col(2));
  cof.col(1) = F.col(2).cross(F.col(0));
  cof.col(2) = F.col(0).cross(F.col(1));
  const double pressure = lambda * (F.determinant() - alpha);
  Eigen::Matrix<double, 9, 1> g;
  for (int v = 0; v < 9; ++v) g[v] = cof(v / 3, v % 3);
  Eigen::Matrix<double, 9, 9> H =
      w.mu * Eigen::Matrix<double, 9, 9>::Identity() + lambda * g * g.transpose();
  // d^2 J / dF_aj dF_dl = e_adm e_jln F_mn
  const auto eps = [](int i, int j, int k) { return 0.5 * (i - j) * (j - k) * (k - i); };
  for (int a = 0; a < 3; ++a)
    for (int j = 0; j < 3; ++j)
      for (int d = 0; d < 3; ++d)
        for (int l = 0; l < 3; ++l) {
          double h = 0.0;
          for (int m = 0; m < 3; ++m)
            for (int n = 0; n < 3; ++n) h += eps(a, d, m) * eps(j, l, n) * F(m, n);
          H(3 * a + j, 3 * d + l) += pressure * h;
        }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eig(H);
  s.tangent = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() *
              eig.eigenvectors().transpose();
  return w.mu * F + pressure * cof;
}

// The Neo-Hookean stress increment along a displacement gradient dH (the tangent).
Eigen::Matrix3d neo_hookean_increment(const NeoState& s, const Eigen::Matrix3d& dH) {
  Eigen::Matrix<double, 9, 1> d;
  for (int v = 0; v < 9; ++v) d[v] = dH(v / 3, v % 3);
  const Eigen::Matrix<double, 9, 1> p = s.tangent * d;
  Eigen::Matrix3d dP;
  for (int v = 0; v < 9; ++v) dP(v / 3, v % 3) = p[v];
  return dP;
}

// The sphere's push at the current u, taken off f_int: a load that follows the surface, so it
// belongs with the forces that depend on u (the residual and reactions see it there).
void press(Workspace& w) {
  if (!w.sphere) return;
  for (int v = 0; v < w.nodes; ++v)
    w.x.row(v) = w.V->row(v) + Eigen::RowVector3d(w.u[3 * v], w.u[3 * v + 1], w.u[3 * v + 2]);
  interact::press_sphere(w.x, *w.V, w.faces, *w.sphere, w.pieces);
  for (const interact::PressedPiece& p : w.pieces)
    for (int c = 0; c < 3; ++c)
      w.f_int.segment<3>(3 * w.faces(p.face, c)) -= p.barycentric[c] * p.force_mn;
}

// Internal forces f_int(u). The corotational law also updates each element's rotation from u
// (linear elasticity keeps the identity); Neo-Hookean its NeoState.
void internal_forces(Workspace& w) {
  const Eigen::Index tets = w.T->rows();
  const bool corotate = w.law == FemLaw::kCorotational;
#pragma omp parallel for schedule(static) if (tets > 4096)
  for (Eigen::Index t = 0; t < tets; ++t) {
    const Eigen::Matrix3d Hu = displacement_gradient(w, t, w.u);
    if (w.law == FemLaw::kNeoHookean) {
      const Eigen::Matrix3d P =
          neo_hookean_stress(w, Eigen::Matrix3d::Identity() + Hu, w.neo[static_cast<size_t>(t)]);
      const Eigen::Matrix<double, 3, 4> f = w.rest_volume[t] * P * w.grad[t].transpose();
      for (int a = 0; a < 4; ++a) w.element_force.col(t).segment<3>(3 * a) = f.col(a);
      continue;
    }
    Eigen::Matrix3d H = Hu;
    if (corotate) {
      const Eigen::Matrix3d F = Eigen::Matrix3d::Identity() + Hu;
      w.rotation[t] = polar_rotation(F);
      H = w.rotation[t].transpose() * F - Eigen::Matrix3d::Identity();
    }
    const Eigen::Matrix3d sigma =
        w.lambda * H.trace() * Eigen::Matrix3d::Identity() + w.mu * (H + H.transpose());
    const Eigen::Matrix<double, 3, 4> f =
        w.rest_volume[t] * w.rotation[t] * sigma * w.grad[t].transpose();
    for (int a = 0; a < 4; ++a) w.element_force.col(t).segment<3>(3 * a) = f.col(a);
  }
  gather(w, w.f_int);
  press(w);
}

// out = K_t d, the tangent (sum of R K_e R^T) times a displacement field, matrix-free: the
// linear force of d measured in each element's frame, rotated back.
void tangent_product(Workspace& w, const Eigen::VectorXd& d, Eigen::VectorXd& out) {
  const Eigen::Index tets = w.T->rows();
#pragma omp parallel for schedule(static) if (tets > 4096)
  for (Eigen::Index t = 0; t < tets; ++t) {
    if (w.law == FemLaw::kNeoHookean) {
      const Eigen::Matrix3d dP =
          neo_hookean_increment(w.neo[static_cast<size_t>(t)], displacement_gradient(w, t, d));
      const Eigen::Matrix<double, 3, 4> f = w.rest_volume[t] * dP * w.grad[t].transpose();
      for (int a = 0; a < 4; ++a) w.element_force.col(t).segment<3>(3 * a) = f.col(a);
      continue;
    }
    const Eigen::Matrix3d& R = w.rotation[t];
    const Eigen::Matrix3d H = R.transpose() * displacement_gradient(w, t, d);
    const Eigen::Matrix3d sigma =
        w.lambda * H.trace() * Eigen::Matrix3d::Identity() + w.mu * (H + H.transpose());
    const Eigen::Matrix<double, 3, 4> f = w.rest_volume[t] * R * sigma * w.grad[t].transpose();
    for (int a = 0; a < 4; ++a) w.element_force.col(t).segment<3>(3 * a) = f.col(a);
  }
  gather(w, out);
}

// K = sum over tets of R K_e R^T on the unknowns, into the fixed pattern.
void assemble_tangent(Workspace& w) {
  double* values = w.K.valuePtr();
  std::fill(values, values + w.K.nonZeros(), 0.0);
  for (Eigen::Index t = 0; t < w.T->rows(); ++t) {
    const int* slot = &w.slot[static_cast<size_t>(t) * 144];
    const Grad& g = w.grad[t];
    const Eigen::Matrix<double, 4, 3> h = g * w.rotation[t].transpose();  // rows: (R g_a)^T
    const double V = w.rest_volume[t];
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b) {
        Eigen::Matrix3d block;
        if (w.law == FemLaw::kNeoHookean) {
          // V sum_jl g_a,j T_(ij),(ml) g_b,l
          const Eigen::Matrix<double, 9, 9>& T = w.neo[static_cast<size_t>(t)].tangent;
          for (int i = 0; i < 3; ++i)
            for (int m = 0; m < 3; ++m) {
              double sum = 0.0;
              for (int j = 0; j < 3; ++j)
                for (int l = 0; l < 3; ++l) sum += g(a, j) * T(3 * i + j, 3 * m + l) * g(b, l);
              block(i, m) = V * sum;
            }
        } else {
          block = V * (w.lambda * h.row(a).transpose() * h.row(b) +
                       w.mu * h.row(b).transpose() * h.row(a) +
                       w.mu * g.row(a).dot(g.row(b)) * Eigen::Matrix3d::Identity());
        }
        for (int i = 0; i < 3; ++i)
          for (int m = 0; m < 3; ++m) {
            const int s = slot[12 * (3 * a + i) + 3 * b + m];
            if (s >= 0) values[s] += block(i, m);
          }
      }
  }
  // The sphere: each piece's k n n^T between its triangle's corners, by their weights. The
  // corners share a boundary tet, so every entry is in the pattern already.
  const int* outer = w.K.outerIndexPtr();
  const int* inner = w.K.innerIndexPtr();
  for (const interact::PressedPiece& p : w.pieces) {
    const Eigen::Matrix3d n2 = p.normal * p.normal.transpose();
    Eigen::Matrix3d nn = p.stiffness_mn_per_mm * n2;
    if (w.contact_curvature)  // the force turning with its normal: softens sideways
      nn -= (p.force_mn.norm() / p.distance_mm) * (Eigen::Matrix3d::Identity() - n2);
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        for (int i = 0; i < 3; ++i)
          for (int m = 0; m < 3; ++m) {
            const int r = w.free_index[3 * w.faces(p.face, a) + i];
            const int c = w.free_index[3 * w.faces(p.face, b) + m];
            if (r < 0 || c < 0) continue;
            const int* at = std::lower_bound(inner + outer[c], inner + outer[c + 1], r);
            values[at - inner] += p.barycentric[a] * p.barycentric[b] * nn(i, m);
          }
  }
}

bool factorize(Workspace& w) {
  w.factored = w.factor.factorize(w.K);
  return w.factored;
}

// Conjugate gradients on the current K, preconditioned by the sparse factor of an earlier K
// (sparse_factor.h). Returns the iterations taken, or -1 if `max_iterations` did not reach the
// tolerance.
int preconditioned_cg(Workspace& w, double tolerance, int max_iterations) {
  const double stop = tolerance * w.rhs.norm();
  w.step.setZero();
  w.cg_r = w.rhs;
  w.factor.solve(w.cg_r, w.cg_z);
  w.cg_p = w.cg_z;
  double rz = w.cg_r.dot(w.cg_z);
  for (int k = 0; k < max_iterations; ++k) {
    if (!(w.cg_r.norm() > stop)) return std::isfinite(rz) ? k : -1;
    w.check.noalias() = w.K * w.cg_p;
    const double alpha = rz / w.cg_p.dot(w.check);
    w.step += alpha * w.cg_p;
    w.cg_r -= alpha * w.check;
    w.factor.solve(w.cg_r, w.cg_z);
    const double rz_next = w.cg_r.dot(w.cg_z);
    w.cg_p = w.cg_z + (rz_next / rz) * w.cg_p;
    rz = rz_next;
  }
  return w.cg_r.norm() <= stop ? max_iterations : -1;
}

// Solves K step = rhs on the unknowns to a relative `tolerance`.
//  - Factorising K (CHOLMOD, or LDL^T) costs far more than using a factor (on a 7.9k-tet ball:
//    0.35 s against ~2 ms per preconditioned iteration), and the corotational tangent changes
//    little between iterations, so a factor is kept and used to precondition conjugate
//    gradients on the current K. That gives the step the current tangent asks for, in a few
//    iterations; K is refactorised only when that takes more than kRefactorAfter of them.
//  - A fresh factor's own answer is checked, and polished by the same preconditioned CG if
//    round-off spoiled it (slivers make K ill-conditioned).
//  - If the factorisation fails, plain (Jacobi-preconditioned) conjugate gradients.
// Returns false if no method reached the tolerance with a finite answer.
constexpr int kRefactorAfter = 8;
bool linear_solve(Workspace& w, double tolerance) {
  const double rhs_norm = w.rhs.norm();
  if (rhs_norm == 0.0) {
    w.step.setZero();
    return true;
  }
  if (w.factored) {
    const int k = preconditioned_cg(w, tolerance, kRefactorAfter);
    if (k >= 0 && w.step.allFinite()) return true;
  }
  if (factorize(w)) {
    w.factor.solve(w.rhs, w.step);
    w.check.noalias() = w.K * w.step;
    w.check -= w.rhs;
    if (w.step.allFinite() && w.check.norm() <= tolerance * rhs_norm) return true;
    const int k = preconditioned_cg(w, tolerance, kRefactorAfter);
    if (k >= 0 && w.step.allFinite()) return true;
  }
  w.cg.setTolerance(tolerance);
  w.cg.setMaxIterations(std::max(1000, 4 * w.unknowns));
  w.cg.compute(w.K);
  w.step = w.cg.solve(w.rhs);
  w.check.noalias() = w.K * w.step;
  w.check -= w.rhs;
  return w.step.allFinite() && w.check.norm() <= tolerance * rhs_norm;
}

// Out-of-balance force on the unknowns at the current u, relative to the largest force met so
// far in this solve (internal plus external, or that of a load increment). Not relative to the
// current forces alone: those vanish as a body approaches a rigid motion, and the residual
// with them.
double relative_residual(Workspace& w, double load_scale) {
  for (size_t d = 0; d < w.free_index.size(); ++d)
    if (w.free_index[d] >= 0) w.residual[w.free_index[d]] = w.f_int[d] - load_scale * w.f_ext[d];
  const double r = w.residual.norm();
  const double forces = w.f_int.norm() + load_scale * w.f_ext.norm();
  if (!std::isfinite(r) || !std::isfinite(forces)) return std::numeric_limits<double>::infinity();
  w.force_scale = std::max(w.force_scale, forces);
  return w.force_scale > 0.0 ? r / w.force_scale : 0.0;
}

void add_step(Workspace& w) {
  for (size_t d = 0; d < w.free_index.size(); ++d)
    if (w.free_index[d] >= 0) w.u[d] += w.step[w.free_index[d]];
}

// The result at the current u, with reactions against the external load at `load` (the
// fraction of it applied so far).
FemResult finish(const TetMesh& mesh, const Workspace& w, double load, int iterations,
                 double residual, bool converged) {
  FemResult result;
  result.u.resize(w.nodes, 3);
  result.reaction_mn = Eigen::MatrixX3d::Zero(w.nodes, 3);
  for (int v = 0; v < w.nodes; ++v)
    for (int c = 0; c < 3; ++c) {
      const int d = 3 * v + c;
      result.u(v, c) = w.u[d];
      if (w.constrained[d]) result.reaction_mn(v, c) = w.f_int[d] - load * w.f_ext[d];
    }
  result.iterations = iterations;
  result.residual = residual;
  result.converged = converged && result.u.allFinite();
  result.volume_mm3 = tet_volume(mesh, mesh.V + result.u);
  result.sphere_push_mn = interact::pressed_total(w.pieces);
  return result;
}

}  // namespace

FemResult solve_linear(const TetMesh& mesh, const FemMaterial& material,
                       const FemBoundary& boundary) {
  if (boundary.sphere)
    throw invalid_input("fem: boundary.sphere",
                        "a pressing sphere needs a nonlinear solve (corotational or Neo-Hookean)");
  Workspace w;
  setup(mesh, material, boundary, w);
  // Prescribed values first; their forces on the unknowns move to the right-hand side.
  for (size_t d = 0; d < w.constrained.size(); ++d)
    if (w.constrained[d]) w.u[d] = w.target[d];
  internal_forces(w);
  relative_residual(w, 1.0);
  assemble_tangent(w);
  w.rhs = -w.residual;
  const bool solved = linear_solve(w, 0.1 * kLinearTolerance);
  add_step(w);
  internal_forces(w);
  const double residual = relative_residual(w, 1.0);
  return finish(mesh, w, 1.0, 1, residual, solved && residual <= kLinearTolerance);
}

namespace {

// Below this relative residual the sphere's tangent includes its curvature (Workspace).
constexpr double kContactCurvatureBelow = 1e-3;

// Load steps of Newton-like iterations on the law's tangent (solve_corotational()).
FemResult solve_nonlinear(const TetMesh& mesh, const FemMaterial& material,
                          const FemBoundary& boundary, const FemOptions& options, FemLaw law) {
  if (options.load_steps < 1)
    throw invalid_input("fem: options.load_steps",
                        fmt::format("must be >= 1, got {}", options.load_steps));
  if (options.max_newton_iterations < 1)
    throw invalid_input("fem: options.max_newton_iterations",
                        fmt::format("must be >= 1, got {}", options.max_newton_iterations));
  if (!finite_number(options.tolerance) || options.tolerance <= 0.0)
    throw invalid_input("fem: options.tolerance",
                        fmt::format("must be finite and > 0, got {}", options.tolerance));
  Workspace w;
  setup(mesh, material, boundary, w);
  w.law = law;
  if (law == FemLaw::kNeoHookean) w.neo.assign(static_cast<size_t>(mesh.T.rows()), NeoState{});
  internal_forces(w);  // rotations at rest (identity up to round-off)
  // Inexact Newton: the inner solve need only beat the outer iteration's own rate of progress
  // (the R K R^T tangent leaves out the rotation's derivative, so that rate is linear, ~0.1).
  constexpr double inner_tolerance = 1e-3;

  int iterations = 0;
  double residual = 0.0;
  bool all_converged = true;
  const auto started = std::chrono::steady_clock::now();
  for (int s = 1; s <= options.load_steps; ++s) {
    // (`-v`: a reference at 43k nodes takes minutes per load step; say it is alive.)
    if (s > 1)
      log::debug(
          "fem ({}): load step {} of {} done, {} iterations so far, residual {:.2g}, {:.0f} s",
          law == FemLaw::kNeoHookean ? "Neo-Hookean" : "corotational", s - 1, options.load_steps,
          iterations, residual,
          std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
    const double load = static_cast<double>(s) / options.load_steps;
    w.contact_curvature = false;
    if (w.sphere) {  // the sphere's centre takes this step's place; its push follows
      w.sphere->center_mm = w.sphere_start + load * (w.sphere_end - w.sphere_start);
      internal_forces(w);
    }
    // Predictor: move the prescribed components to this step's values and let the first solve
    // account for them through the tangent (K_fc du_c on the right-hand side), rather than
    // jumping them alone, which would crush the boundary layer of elements.
    w.work.setZero();
    for (size_t d = 0; d < w.constrained.size(); ++d)
      if (w.constrained[d]) w.work[d] = load * w.target[d] - w.u[d];
    if (w.unknowns == 0) {
      w.u += w.work;
      internal_forces(w);
      residual = relative_residual(w, load);
      if (!std::isfinite(residual)) return finish(mesh, w, load, iterations, residual, false);
      continue;
    }
    relative_residual(w, load);
    tangent_product(w, w.work, w.f_int);  // f_int is recomputed below; reuse it as scratch
    for (size_t d = 0; d < w.free_index.size(); ++d)
      if (w.free_index[d] >= 0) w.rhs[w.free_index[d]] = -w.residual[w.free_index[d]] - w.f_int[d];
    w.force_scale = std::max(w.force_scale, w.rhs.norm());
    assemble_tangent(w);
    bool step_converged = false;
    for (int it = 0; it < options.max_newton_iterations; ++it) {
      w.u_saved = w.u;
      linear_solve(w, inner_tolerance);  // an inexact answer still counts: the residual judges
      ++iterations;
      add_step(w);
      if (it == 0) w.u += w.work;
      internal_forces(w);
      residual = relative_residual(w, load);
      if (!std::isfinite(residual) || !w.u.allFinite()) {
        // Back to the last finite state; before this step's first update, that is the
        // previous load step's.
        w.u = w.u_saved;
        internal_forces(w);
        const double held = it == 0 ? static_cast<double>(s - 1) / options.load_steps : load;
        return finish(mesh, w, held, iterations, std::numeric_limits<double>::infinity(), false);
      }
      if (residual <= options.tolerance) {
        step_converged = true;
        break;
      }
      // The sphere's full tangent converges where the positive part alone crawls (linearly,
      // levelling off near 1e-4 of the force at a 20% indentation), but far from the answer its
      // indefinite part can carry the surface through the sphere: near the answer only.
      w.contact_curvature = w.sphere && residual < kContactCurvatureBelow;
      w.rhs = -w.residual;
      assemble_tangent(w);
    }
    // With the sphere only the last step's equilibrium counts: the earlier ones are a path to
    // it, and a frictionless elastic body at rest does not remember the path it took (one that
    // snapped through would show in the force and the field).
    all_converged = (all_converged || (w.sphere && s == options.load_steps)) && step_converged;
  }
  return finish(mesh, w, 1.0, iterations, residual, all_converged);
}

}  // namespace

FemResult solve_corotational(const TetMesh& mesh, const FemMaterial& material,
                             const FemBoundary& boundary, const FemOptions& options) {
  return solve_nonlinear(mesh, material, boundary, options, FemLaw::kCorotational);
}

FemResult solve_neo_hookean(const TetMesh& mesh, const FemMaterial& material,
                            const FemBoundary& boundary, const FemOptions& options) {
  return solve_nonlinear(mesh, material, boundary, options, FemLaw::kNeoHookean);
}

}  // namespace lamina::validate
