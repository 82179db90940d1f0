#include "lamina/validate/indentation.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <nanoflann.hpp>

#include "lamina/core/clock.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/geometry/closest_on_triangle.h"
#include "lamina/interact/contact.h"
#include "lamina/interact/tools.h"
#include "lamina/model/layer_normals.h"

namespace lamina::validate {
namespace {

bool in_slab(const Eigen::Vector3d& p, const Indentation& ind) {
  return std::abs((p - ind.held_point_mm).dot(ind.held_normal.normalized())) <=
         ind.held_distance_mm;
}

// u sampled at each point of `samples` from the nearest point of the boundary faces F.
Eigen::MatrixX3d sample_on_faces(const TetMesh& mesh, const Eigen::MatrixX3i& F,
                                 const Eigen::MatrixX3d& u, const Eigen::MatrixX3d& samples) {
  using Points = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
  Points centroids(F.rows(), 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    centroids.row(f) = (mesh.V.row(F(f, 0)) + mesh.V.row(F(f, 1)) + mesh.V.row(F(f, 2))) / 3.0;
  const nanoflann::KDTreeEigenMatrixAdaptor<Points, 3, nanoflann::metric_L2_Simple> tree(
      3, std::cref(centroids), 16);
  const size_t k = std::min<size_t>(16, static_cast<size_t>(F.rows()));
  std::vector<Eigen::Index> idx(k);
  std::vector<double> d2(k);
  Eigen::MatrixX3d out(samples.rows(), 3);
  for (Eigen::Index s = 0; s < samples.rows(); ++s) {
    const Eigen::Vector3d p = samples.row(s).transpose();
    const double q[3] = {p.x(), p.y(), p.z()};
    tree.query(q, k, idx.data(), d2.data());
    double best = std::numeric_limits<double>::infinity();
    for (size_t n = 0; n < k; ++n) {
      const Eigen::Index f = idx[n];
      const Eigen::Vector3d a = mesh.V.row(F(f, 0)), b = mesh.V.row(F(f, 1)),
                            c = mesh.V.row(F(f, 2));
      const Eigen::Vector3d w = geometry::closest_on_triangle(p, a, b, c);
      const double dist = (w[0] * a + w[1] * b + w[2] * c - p).squaredNorm();
      if (dist < best) {
        best = dist;
        out.row(s) = w[0] * u.row(F(f, 0)) + w[1] * u.row(F(f, 1)) + w[2] * u.row(F(f, 2));
      }
    }
  }
  return out;
}

// Where the indentation's sphere first touches the surface (x, F) coming along its direction
// to the contact point: from a start clear of the surface, farther back until it is.
Eigen::Vector3d first_touch(const Eigen::MatrixX3d& x, const Eigen::MatrixX3i& F,
                            const Indentation& ind, const std::string& what) {
  const Eigen::Vector3d d = ind.direction.normalized();
  const double r = ind.radius_mm;
  for (double back = 2.0 * r; back <= 64.0 * r; back *= 2.0) {
    const Eigen::Vector3d from = ind.contact_mm - back * d;
    if (const auto touch =
            interact::sphere_first_touch(x, F, from, d, r, back + ind.organ_depth_mm + r))
      return *touch;
  }
  throw invalid_input(what, fmt::format("the indenter sphere ({} mm) finds no clear path to the "
                                        "contact point along the indentation's direction",
                                        r));
}

// The FEM answer's volume change and its displacement, whole and sampled at `samples` on the
// boundary faces F.
void measure_fem(const TetMesh& mesh, const Eigen::MatrixX3i& F, const FemResult& fem,
                 const Eigen::MatrixX3d& samples, IndentResult& r) {
  const double v0 = tet_volume(mesh, mesh.V);
  r.volume_change_pct = 100.0 * (fem.volume_mm3 - v0) / v0;
  r.skin_u = sample_on_faces(mesh, F, fem.u, samples);
  r.u = fem.u;
}

// The skin's displacement and the organ's volume change of a model at positions x.
void measure_model(const Model& m, const Eigen::MatrixX3d& x, IndentResult& r) {
  const ModelLayer& skin = m.layers[0];
  r.skin_u = x.middleRows(skin.first_node, skin.node_count) -
             m.X.middleRows(skin.first_node, skin.node_count);
  const double v0 = sim::layer_volume(m, m.X, 0);
  r.volume_change_pct = 100.0 * (sim::layer_volume(m, x, 0) - v0) / v0;
}

}  // namespace

Indentation paper_indentation(const Model& m, double radius_mm) {
  const int32_t front = interact::most_anterior_skin_node(m);
  Indentation ind;
  ind.contact_mm = m.X.row(front).transpose();
  ind.direction = Eigen::Vector3d::UnitY();
  ind.radius_mm = radius_mm;
  for (const interact::Crossing& c : interact::force_line_crossings(m, m.X, front, ind.direction))
    if (c.layer == 0) ind.organ_depth_mm = std::max(ind.organ_depth_mm, c.distance_mm);
  ind.held_point_mm = Eigen::Vector3d(0.0, m.X.col(1).maxCoeff(), 0.0);
  ind.held_normal = Eigen::Vector3d::UnitY();
  ind.held_distance_mm = 10.0;
  return ind;
}

Indentation deepest_indentation(const Model& m, double radius_mm) {
  Indentation ind = paper_indentation(m, radius_mm);
  const int32_t skin = m.layers[0].node_count;
  // Only a skin node facing forward (-y) is pushed into the organ by +y.
  const Eigen::MatrixX3d normal = model::layer_normals(m);
  const int32_t stride = std::max(1, skin / 400);
  double deepest = 0.0;
  for (int32_t i = 0; i < skin; i += stride) {
    if (in_slab(m.X.row(i).transpose(), ind) || normal(i, 1) > -0.5) continue;
    for (const interact::Crossing& c :
         interact::force_line_crossings(m, m.X, i, Eigen::Vector3d::UnitY()))
      if (c.layer == 0 && c.distance_mm > 0.0) {  // the first exit: the local depth
        if (c.distance_mm > deepest) {
          deepest = c.distance_mm;
          ind.contact_mm = m.X.row(i).transpose();
          ind.organ_depth_mm = c.distance_mm;
        }
        break;
      }
  }
  return ind;
}

IndentResult indent_mass_spring(const Model& m, const sim::Material& material,
                                sim::SolverOptions solver, const Indentation& ind, double depth_mm,
                                int ramp) {
  const auto t0 = Clock::now();
  solver.mode = sim::Mode::kGlobal;
  sim::Simulation s = sim::make_simulation(m, material, solver);
  std::vector<int32_t> held, patch;
  for (int32_t i = 0; i < m.node_count(); ++i) {
    const Eigen::Vector3d p = m.X.row(i).transpose();
    if (in_slab(p, ind))
      held.push_back(i);
    else if (m.layer_of[i] == 0 && (p - ind.contact_mm).norm() <= ind.radius_mm)
      patch.push_back(i);
  }
  if (patch.empty())
    throw invalid_input(m.source, "no skin node within the indenter's radius of the contact");
  sim::fix_nodes(s, held);
  IndentResult r;
  r.converged = true;
  const Eigen::RowVector3d dir = ind.direction.normalized().transpose();
  Eigen::MatrixX3d at(static_cast<Eigen::Index>(patch.size()), 3);
  for (int k = 1; k <= std::max(ramp, 1); ++k) {
    const double d = depth_mm * k / std::max(ramp, 1);
    for (size_t q = 0; q < patch.size(); ++q)
      at.row(static_cast<Eigen::Index>(q)) = m.X.row(patch[q]) + d * dir;
    sim::hold_nodes(s, patch, at);
    const sim::StepStats st = sim::run_to_convergence(s);
    r.converged = r.converged && st.converged;
  }
  r.steps = s.steps;
  // The indenter holds the patch against the tissue's internal forces on it.
  Eigen::MatrixX3d f = Eigen::MatrixX3d::Zero(m.node_count(), 3);
  sim::internal_forces(s, s.x, f);
  double push = 0.0;
  for (int32_t i : patch) push -= f.row(i).dot(dir);
  r.force_n = push / 1000.0;  // mN -> N
  measure_model(m, s.x, r);
  r.seconds = seconds_since(t0);
  return r;
}

IndentResult indent_fem(const TetMesh& mesh, const FemMaterial& material, const Indentation& ind,
                        double depth_mm, FemLaw law, const Eigen::MatrixX3d& samples,
                        const FemOptions& options) {
  const auto t0 = Clock::now();
  const Eigen::MatrixX3i F = boundary_faces(mesh);
  std::vector<uint8_t> on_boundary(static_cast<size_t>(mesh.V.rows()), 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) on_boundary[F(f, c)] = 1;
  FemBoundary bc;
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v) {
    const Eigen::Vector3d p = mesh.V.row(v).transpose();
    if (in_slab(p, ind))
      bc.fixed.push_back(static_cast<int32_t>(v));
    else if (on_boundary[v] && (p - ind.contact_mm).norm() <= ind.radius_mm)
      bc.driven.push_back(static_cast<int32_t>(v));
  }
  if (bc.driven.empty())
    throw invalid_input("finite-element mesh",
                        "no boundary vertex within the indenter's radius of the contact");
  const Eigen::RowVector3d dir = ind.direction.normalized().transpose();
  bc.driven_displacement_mm =
      (depth_mm * dir).replicate(static_cast<Eigen::Index>(bc.driven.size()), 1);
  const FemResult fem =
      law == FemLaw::kCorotational ? solve_corotational(mesh, material, bc, options)
      : law == FemLaw::kNeoHookean ? solve_neo_hookean(mesh, material, bc, options)
                                   : solve_linear(mesh, material, bc);
  IndentResult r;
  r.converged = fem.converged;
  r.steps = fem.iterations;
  double push = 0.0;
  for (int32_t v : bc.driven) push += fem.reaction_mn.row(v).dot(dir);
  r.force_n = push / 1000.0;
  measure_fem(mesh, F, fem, samples, r);
  r.seconds = seconds_since(t0);
  return r;
}

IndentResult press_mass_spring(const Model& m, const sim::Material& material,
                               sim::SolverOptions solver, const Indentation& ind, double depth_mm,
                               double travel_s) {
  const auto t0 = Clock::now();
  solver.mode = sim::Mode::kGlobal;
  sim::Simulation s = sim::make_simulation(m, material, solver);
  sim::fix_nodes(
      s, sim::nodes_near_plane(m, ind.held_point_mm, ind.held_normal, ind.held_distance_mm));
  const Eigen::Vector3d dir = ind.direction.normalized();
  const Eigen::Vector3d touch = first_touch(m.X, m.layers[0].F, ind, m.source);
  interact::PressingSphere sphere{.center_mm = touch,
                                  .radius_mm = ind.radius_mm,
                                  .stiffness_kpa_per_mm = ind.sphere_stiffness_kpa_per_mm};
  IndentResult r;
  interact::ForceRoute route;
  const auto load = [&] {  // the sphere's push on the current skin, into f_ext
    route = interact::sphere_contact(m, s.x, sphere);
    s.f_ext.setZero();
    for (size_t k = 0; k < route.nodes.size(); ++k)
      s.f_ext.row(route.nodes[k]) = route.forces.row(static_cast<Eigen::Index>(k));
  };
  // The sphere moves on at a steady speed (a jump would hit the skin with the whole
  // penetration's force in one explicit step), then stays while the model comes to rest.
  const auto moving = static_cast<int64_t>(std::ceil(travel_s / s.options().dt_s));
  sim::RestStreak rest{.needed = sim::quiet_steps(s)};
  bool settled = false;
  for (int64_t n = 0; n < solver.max_steps && !settled; ++n) {
    sphere.center_mm = touch + (depth_mm * std::min<double>(n + 1, moving) / moving) * dir;
    load();
    const sim::StepStats st = sim::step(s);
    if (st.failed) break;
    settled = n + 1 >= moving && rest.update(st);
  }
  r.converged = settled;
  load();
  r.steps = s.steps;
  r.force_n = interact::total_force(route).dot(dir) / 1000.0;  // mN -> N
  measure_model(m, s.x, r);
  r.seconds = seconds_since(t0);
  return r;
}

IndentResult press_fem(const TetMesh& mesh, const FemMaterial& material, const Indentation& ind,
                       double depth_mm, FemLaw law, const Eigen::MatrixX3d& samples,
                       const FemOptions& options) {
  const auto t0 = Clock::now();
  const Eigen::MatrixX3i F = boundary_faces(mesh);
  FemBoundary bc;
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v)
    if (in_slab(mesh.V.row(v).transpose(), ind)) bc.fixed.push_back(static_cast<int32_t>(v));
  bc.driven_displacement_mm.resize(0, 3);
  bc.sphere_start_mm = first_touch(mesh.V, F, ind, "finite-element mesh");
  bc.sphere = interact::PressingSphere{
      .center_mm = bc.sphere_start_mm + depth_mm * ind.direction.normalized(),
      .radius_mm = ind.radius_mm,
      .stiffness_kpa_per_mm = ind.sphere_stiffness_kpa_per_mm};
  const FemResult fem = law == FemLaw::kNeoHookean
                            ? solve_neo_hookean(mesh, material, bc, options)
                            : solve_corotational(mesh, material, bc, options);
  if (!fem.converged)
    log::warn(
        "validate: the sphere-pressed FEM missed its tolerance {:g} (residual {:.3g} after "
        "{} solves)",
        options.tolerance, fem.residual, fem.iterations);
  IndentResult r;
  r.converged = fem.converged;
  r.steps = fem.iterations;
  r.force_n = fem.sphere_push_mn.dot(ind.direction.normalized()) / 1000.0;
  measure_fem(mesh, F, fem, samples, r);
  r.seconds = seconds_since(t0);
  return r;
}

Eigen::MatrixX3d sample_on_boundary(const TetMesh& mesh, const Eigen::MatrixX3d& u,
                                    const Eigen::MatrixX3d& samples) {
  return sample_on_faces(mesh, boundary_faces(mesh), u, samples);
}

FieldError field_error(const Eigen::MatrixX3d& u, const Eigen::MatrixX3d& reference) {
  FieldError e;
  if (u.rows() != reference.rows() || u.rows() == 0) return e;
  const Eigen::VectorXd d = (u - reference).rowwise().norm();
  e.rms_mm = std::sqrt(d.squaredNorm() / static_cast<double>(d.size()));
  e.max_mm = d.maxCoeff();
  e.reference_max_mm = reference.rowwise().norm().maxCoeff();
  return e;
}

}  // namespace lamina::validate
