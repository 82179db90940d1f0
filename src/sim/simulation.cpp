#include "lamina/sim/simulation.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>

#include "lamina/core/error.h"

namespace lamina::sim {
namespace {

// kg (mm/s)^2 -> J.
constexpr double kJoulesPerKgMm2PerS2 = 1e-6;

// Below this many rows a parallel region costs more than it saves (a paper-size model's whole
// spring pass is tens of microseconds); loops run serially there.
constexpr Eigen::Index kParallelRows = 8192;

// Forces that do not come from springs: external, damping, gravity, anchors. Added to f.
void add_node_forces(const Simulation& s, const Eigen::MatrixX3d& x, const Eigen::MatrixX3d& v,
                     Eigen::MatrixX3d& f) {
  const Material& mat = s.material;
  const Eigen::MatrixX3d& X = s.model->X;
  const Eigen::Index n = x.rows();
#pragma omp parallel for schedule(static) if (n >= kParallelRows)
  for (Eigen::Index i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c)
      f(i, c) += s.f_ext(i, c) - mat.damping_kg_per_s * v(i, c) +
                 s.mass_kg[i] * mat.gravity_mm_per_s2[c] -
                 mat.anchor_stiffness_n_per_m * (x(i, c) - X(i, c));
}

bool all_finite_and_bounded(const Simulation& s, double limit_mm) {
  // A blow-up can stay finite for a few steps while growing without bound: treat a node far
  // outside the model's reach as unstable too.
  const Eigen::MatrixX3d& X = s.model->X;
  bool ok = true;
  for (Eigen::Index i = 0; i < s.x.rows() && ok; ++i)
    for (int c = 0; c < 3; ++c)
      ok &= std::isfinite(s.x(i, c)) && std::isfinite(s.v(i, c)) &&
            std::abs(s.x(i, c) - X(i, c)) < limit_mm;
  return ok;
}

// Semi-implicit (symplectic) Euler, the paper's: v += dt a(x, v); x += dt v.
void semi_implicit_euler(Simulation& s, double dt) {
  s.f.setZero();
  spring_forces(s, s.x, s.f);
  add_node_forces(s, s.x, s.v, s.f);
  const Eigen::Index n = s.x.rows();
#pragma omp parallel for schedule(static) if (n >= kParallelRows)
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!s.movable[i]) {
      s.v.row(i).setZero();
      continue;
    }
    for (int c = 0; c < 3; ++c) {
      s.v(i, c) += dt * s.f(i, c) / s.mass_kg[i];
      s.x(i, c) += dt * s.v(i, c);
    }
  }
}

// y = (M + h gamma + h^2 K) p on movable nodes, K the spring (and anchor) stiffness matrix
// linearised at the current positions (directions and 1 - L/l cached in s.dir).
void system_product(const Simulation& s, double h, const Eigen::MatrixX3d& p, Eigen::MatrixX3d& y) {
  const Eigen::Index n = p.rows();
  const double h2 = h * h, damp = h * s.material.damping_kg_per_s;
  const double anchor = s.material.anchor_stiffness_n_per_m;
#pragma omp parallel for schedule(static) if (n >= kParallelRows)
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!s.movable[i]) {
      y.row(i).setZero();
      continue;
    }
    Eigen::Vector3d kp = anchor * p.row(i).transpose();
    for (int32_t a = s.adj_offsets[i]; a < s.adj_offsets[i + 1]; ++a) {
      const int32_t e = s.adj_spring[a], j = s.adj_other[a];
      const Eigen::Vector3d d = p.row(i).transpose() - p.row(j).transpose();
      const Eigen::Vector3d u = s.dir.row(e).head<3>().transpose();
      const double alpha = s.dir(e, 3);
      const double along = u.dot(d);
      // k [u u^T + alpha (I - u u^T)] d
      kp += s.stiffness_n_per_m[e] * (along * u + alpha * (d - along * u));
    }
    y.row(i) = (s.mass_kg[i] + damp) * p.row(i) + h2 * kp.transpose();
  }
}

// Backward Euler, linearised once per step (Baraff-Witkin):
//   (M + h gamma + h^2 K) dv = h (f(x, v) - h K v),   v += dv,   x += h v.
// K's geometric term is clamped at max(0, 1 - L/l) so the matrix stays positive definite under
// compression and CG applies. Jacobi-preconditioned, warm-started from dv = 0.
int32_t implicit_euler(Simulation& s, double h) {
  const Eigen::Index n = s.x.rows();
  const int64_t springs = static_cast<int64_t>(s.model->springs.size());
  const Springs& sp = s.model->springs;
#pragma omp parallel for schedule(static) if (springs >= kParallelRows)
  for (int64_t e = 0; e < springs; ++e) {
    Eigen::Vector3d d = s.x.row(sp.i[e]).transpose() - s.x.row(sp.j[e]).transpose();
    const double l = d.norm();
    if (l > 0.0) d /= l;
    s.dir.row(e) << d.transpose(), l > 0.0 ? std::max(0.0, 1.0 - sp.rest_length_mm[e] / l) : 0.0;
  }
  s.f.setZero();
  spring_forces(s, s.x, s.f);
  add_node_forces(s, s.x, s.v, s.f);
  // rhs = h f - h^2 K v: K v from the product with the damping and mass terms taken out.
  system_product(s, h, s.v, s.q);
  const double h2 = h * h, damp = h * s.material.damping_kg_per_s;
  const double anchor = s.material.anchor_stiffness_n_per_m;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!s.movable[i]) {
      s.r.row(i).setZero();
      s.diag.row(i).setOnes();
      continue;
    }
    s.r.row(i) = h * s.f.row(i) - (s.q.row(i) - (s.mass_kg[i] + damp) * s.v.row(i));
    for (int c = 0; c < 3; ++c) {
      double k_diag = anchor;
      for (int32_t a = s.adj_offsets[i]; a < s.adj_offsets[i + 1]; ++a) {
        const int32_t e = s.adj_spring[a];
        const double u = s.dir(e, c), alpha = s.dir(e, 3);
        k_diag += s.stiffness_n_per_m[e] * (u * u + alpha * (1.0 - u * u));
      }
      s.diag(i, c) = s.mass_kg[i] + damp + h2 * k_diag;
    }
  }
  // Conjugate gradients on dv (stored in s.x_prev's twin, s.p is the search direction).
  Eigen::MatrixX3d& dv = s.q;
  dv.setZero();
  s.z = s.r.cwiseQuotient(s.diag);
  s.p = s.z;
  double rz = s.r.cwiseProduct(s.z).sum();
  const double r0 = std::sqrt(s.r.squaredNorm());
  int32_t it = 0;
  Eigen::MatrixX3d& ap = s.f;  // forces are no longer needed: reuse as A p
  for (; it < s.options.cg_max_iterations && r0 > 0.0; ++it) {
    system_product(s, h, s.p, ap);
    const double pap = s.p.cwiseProduct(ap).sum();
    if (!(pap > 0.0)) break;
    const double alpha = rz / pap;
    dv += alpha * s.p;
    s.r -= alpha * ap;
    if (std::sqrt(s.r.squaredNorm()) <= s.options.cg_tolerance * r0) {
      ++it;
      break;
    }
    s.z = s.r.cwiseQuotient(s.diag);
    const double rz_new = s.r.cwiseProduct(s.z).sum();
    s.p = s.z + (rz_new / rz) * s.p;
    rz = rz_new;
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!s.movable[i]) {
      s.v.row(i).setZero();
      continue;
    }
    s.v.row(i) += dv.row(i);
    s.x.row(i) += h * s.v.row(i);
  }
  return it;
}

}  // namespace

void check_parameters(const Material& m, const SolverOptions& o) {
  auto positive = [](double v) { return v > 0.0 && std::isfinite(v); };
  auto non_negative = [](double v) { return v >= 0.0 && std::isfinite(v); };
  if (!non_negative(m.stiffness_n_per_m))
    throw invalid_input("material.stiffness", "must be >= 0 N/m (0 keeps the model's)");
  if (!non_negative(m.damping_kg_per_s))
    throw invalid_input("material.damping", "must be >= 0 kg/s");
  if (!non_negative(m.node_mass_kg))
    throw invalid_input("material.node_mass", "must be >= 0 kg (0 uses the model's masses)");
  if (!non_negative(m.anchor_stiffness_n_per_m))
    throw invalid_input("material.anchor_stiffness", "must be >= 0 N/m");
  if (!m.gravity_mm_per_s2.allFinite()) throw invalid_input("material.gravity", "must be finite");
  if (!positive(o.dt_s)) throw invalid_input("solver.dt", "must be > 0 s");
  if (!positive(o.threshold_mm)) throw invalid_input("solver.threshold", "must be > 0 mm");
  if (o.max_steps < 1) throw invalid_input("solver.max_steps", "must be >= 1");
  if (o.cg_max_iterations < 1) throw invalid_input("solver.cg_max_iterations", "must be >= 1");
}

Simulation make_simulation(const Model& model, const Material& material,
                           const SolverOptions& options) {
  check_parameters(material, options);
  Simulation s;
  s.model = &model;
  s.material = material;
  s.options = options;
  const int32_t n = model.node_count();
  s.x = model.X;
  s.v = Eigen::MatrixX3d::Zero(n, 3);
  s.f_ext = Eigen::MatrixX3d::Zero(n, 3);
  s.mass_kg = material.node_mass_kg > 0.0
                  ? std::vector<double>(static_cast<size_t>(n), material.node_mass_kg)
                  : model.mass_kg;
  s.fixed = model.fixed.empty() ? std::vector<uint8_t>(static_cast<size_t>(n), 0) : model.fixed;
  s.movable.resize(static_cast<size_t>(n));
  for (int32_t i = 0; i < n; ++i) s.movable[i] = options.mode == Mode::kGlobal && !s.fixed[i];

  const Springs& sp = model.springs;
  s.stiffness_n_per_m = material.stiffness_n_per_m > 0.0
                            ? std::vector<double>(sp.size(), material.stiffness_n_per_m)
                            : sp.stiffness_n_per_m;
  s.adj_offsets.assign(static_cast<size_t>(n) + 1, 0);
  for (size_t e = 0; e < sp.size(); ++e) ++s.adj_offsets[sp.i[e] + 1], ++s.adj_offsets[sp.j[e] + 1];
  for (int32_t i = 0; i < n; ++i) s.adj_offsets[i + 1] += s.adj_offsets[i];
  s.adj_other.resize(static_cast<size_t>(s.adj_offsets[n]));
  s.adj_spring.resize(s.adj_other.size());
  std::vector<int32_t> fill(s.adj_offsets.begin(), s.adj_offsets.end() - 1);
  for (size_t e = 0; e < sp.size(); ++e) {
    const int32_t a = sp.i[e], b = sp.j[e];
    s.adj_other[fill[a]] = b, s.adj_spring[fill[a]++] = static_cast<int32_t>(e);
    s.adj_other[fill[b]] = a, s.adj_spring[fill[b]++] = static_cast<int32_t>(e);
  }
  s.rest_skin_volume_mm3 = layer_volume(model, model.X, 0);
  s.blowup_limit_mm =
      100.0 * (model.X.colwise().maxCoeff() - model.X.colwise().minCoeff()).norm() + 1.0;
  for (Eigen::MatrixX3d* m : {&s.f, &s.x_prev, &s.v_prev, &s.r, &s.p, &s.z, &s.q})
    *m = Eigen::MatrixX3d::Zero(n, 3);
  s.diag = Eigen::MatrixX3d::Ones(n, 3);
  s.dir = Eigen::Matrix<double, Eigen::Dynamic, 4>::Zero(static_cast<Eigen::Index>(sp.size()), 4);
  return s;
}

void set_parameters(Simulation& s, const Material& material, const SolverOptions& options) {
  check_parameters(material, options);
  const Model& m = *s.model;
  const size_t n = static_cast<size_t>(m.node_count());
  if (material.node_mass_kg != s.material.node_mass_kg)
    s.mass_kg =
        material.node_mass_kg > 0.0 ? std::vector<double>(n, material.node_mass_kg) : m.mass_kg;
  if (material.stiffness_n_per_m != s.material.stiffness_n_per_m)
    s.stiffness_n_per_m = material.stiffness_n_per_m > 0.0
                              ? std::vector<double>(m.springs.size(), material.stiffness_n_per_m)
                              : m.springs.stiffness_n_per_m;
  if (options.mode == Mode::kGlobal && s.options.mode != Mode::kGlobal)
    for (size_t i = 0; i < n; ++i) s.movable[i] = !s.fixed[i];
  s.material = material;
  s.options = options;
}

void fix_nodes(Simulation& s, const std::vector<int32_t>& nodes) {
  for (int32_t i : nodes) {
    if (i < 0 || i >= s.model->node_count())
      throw invalid_input("fixed nodes", "node " + std::to_string(i) + " is not in the model (0.." +
                                             std::to_string(s.model->node_count() - 1) + ")");
    s.fixed[i] = 1;
    s.movable[i] = 0;
    s.x.row(i) = s.model->X.row(i);
    s.v.row(i).setZero();
  }
}

std::vector<int32_t> nodes_near_plane(const Model& model, const Eigen::Vector3d& point,
                                      const Eigen::Vector3d& normal, double distance_mm) {
  const Eigen::Vector3d n = normal.normalized();
  std::vector<int32_t> out;
  for (int32_t i = 0; i < model.node_count(); ++i)
    if (std::abs((model.X.row(i).transpose() - point).dot(n)) <= distance_mm) out.push_back(i);
  return out;
}

void set_local_nodes(Simulation& s, const std::vector<int32_t>& nodes) {
  std::fill(s.movable.begin(), s.movable.end(), 0);
  for (int32_t i : nodes)
    if (i >= 0 && i < s.model->node_count() && !s.fixed[i]) s.movable[i] = 1;
}

void spring_forces(const Simulation& s, const Eigen::MatrixX3d& x, Eigen::MatrixX3d& f) {
  const Springs& sp = s.model->springs;
  const Eigen::Index n = x.rows();
  // Gather: each node sums the springs it belongs to, so threads never write the same row. Each
  // spring is evaluated from both ends with the same arithmetic, so the pair is exactly opposite.
#pragma omp parallel for schedule(static) if (n >= kParallelRows)
  for (Eigen::Index i = 0; i < n; ++i) {
    double fx = 0.0, fy = 0.0, fz = 0.0;
    for (int32_t a = s.adj_offsets[i]; a < s.adj_offsets[i + 1]; ++a) {
      const int32_t j = s.adj_other[a], e = s.adj_spring[a];
      const double dx = x(j, 0) - x(i, 0), dy = x(j, 1) - x(i, 1), dz = x(j, 2) - x(i, 2);
      const double l = std::sqrt(dx * dx + dy * dy + dz * dz);
      if (l <= 0.0) continue;
      // Hooke: k (l - L) along the spring, pulling i towards j when stretched.
      const double scale = s.stiffness_n_per_m[e] * (l - sp.rest_length_mm[e]) / l;
      fx += scale * dx, fy += scale * dy, fz += scale * dz;
    }
    f(i, 0) += fx, f(i, 1) += fy, f(i, 2) += fz;
  }
}

double layer_volume(const Model& model, const Eigen::MatrixX3d& x, int32_t layer) {
  const Eigen::MatrixX3i& F = model.layers.at(static_cast<size_t>(layer)).F;
  double v6 = 0.0;
  for (Eigen::Index t = 0; t < F.rows(); ++t)
    v6 += x.row(F(t, 0)).dot(x.row(F(t, 1)).cross(x.row(F(t, 2))));
  return v6 / 6.0;
}

double spring_energy(const Simulation& s, const Eigen::MatrixX3d& x) {
  const Springs& sp = s.model->springs;
  double e = 0.0;
  for (size_t k = 0; k < sp.size(); ++k) {
    const double l = (x.row(sp.i[k]) - x.row(sp.j[k])).norm() - sp.rest_length_mm[k];
    e += 0.5 * s.stiffness_n_per_m[k] * l * l;  // N/m * mm^2 = 1e-3 N mm = 1e-6 J
  }
  return e * kJoulesPerKgMm2PerS2;
}

StepStats step(Simulation& s) {
  const auto t0 = std::chrono::steady_clock::now();
  StepStats st;
  s.x_prev = s.x;
  s.v_prev = s.v;
  const double h = s.options.dt_s;
  const double limit = s.blowup_limit_mm;
  if (s.options.integrator == Integrator::kSemiImplicitEuler)
    semi_implicit_euler(s, h);
  else
    st.cg_iterations = implicit_euler(s, h);
  if (!all_finite_and_bounded(s, limit)) {
    // Roll back and redo: two half steps of the same integrator, then backward Euler (stable at
    // any dt); if even that fails, stop the motion: never let a NaN out.
    st.recovered = true;
    ++s.recoveries;
    s.x = s.x_prev, s.v = s.v_prev;
    if (s.options.integrator == Integrator::kSemiImplicitEuler) {
      semi_implicit_euler(s, 0.5 * h);
      semi_implicit_euler(s, 0.5 * h);
    }
    if (!all_finite_and_bounded(s, limit)) {
      s.x = s.x_prev, s.v = s.v_prev;
      st.cg_iterations = implicit_euler(s, h);
    }
    if (!all_finite_and_bounded(s, limit)) {
      s.x = s.x_prev;
      s.v.setZero();
    }
  }
  s.time_s += h;
  ++s.steps;

  // Measure.
  double move2 = 0.0, disp2 = 0.0, ke = 0.0;
  for (Eigen::Index i = 0; i < s.x.rows(); ++i) {
    move2 = std::max(move2, (s.x.row(i) - s.x_prev.row(i)).squaredNorm());
    disp2 = std::max(disp2, (s.x.row(i) - s.model->X.row(i)).squaredNorm());
    ke += 0.5 * s.mass_kg[i] * s.v.row(i).squaredNorm();
  }
  st.max_move_mm = std::sqrt(move2);
  st.max_displacement_mm = std::sqrt(disp2);
  st.kinetic_energy_j = ke * kJoulesPerKgMm2PerS2;
  st.skin_volume_mm3 = layer_volume(*s.model, s.x, 0);
  st.volume_change_pct =
      100.0 * (st.skin_volume_mm3 - s.rest_skin_volume_mm3) / s.rest_skin_volume_mm3;
  st.converged = st.max_move_mm < s.options.threshold_mm;
  st.step_us =
      std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
  return st;
}

StepStats run_to_convergence(Simulation& s, int64_t quiet_steps) {
  StepStats st;
  int64_t quiet = 0;
  for (int64_t k = 0; k < s.options.max_steps; ++k) {
    st = step(s);
    quiet = st.converged ? quiet + 1 : 0;
    if (quiet >= std::max<int64_t>(1, quiet_steps)) return st;
  }
  st.converged = false;
  return st;
}

}  // namespace lamina::sim
