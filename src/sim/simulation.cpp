#include "lamina/sim/simulation.h"

#include <omp.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>

#include "lamina/core/error.h"
#include "lamina/sim/spring_kernel.h"
#include "step_parts.h"

namespace lamina::sim {
namespace {

using namespace detail;

// kg (mm/s)^2 -> J.
constexpr double kJoulesPerKgMm2PerS2 = 1e-6;

void spring_pass(const Simulation& s, const Eigen::MatrixX3d& x, const int32_t* list,
                 int64_t count, Eigen::MatrixX3d& fs, int threads) {
  const Springs& sp = s.model->springs;
  const ConstCols p(x);
  Cols f(fs);
  for_slices(count, threads, [&](int64_t begin, int64_t end, int) {
    spring_kernel<double>(begin, end, list, sp.i.data(), sp.j.data(), sp.rest_length_mm.data(),
                  s.stiffness_n_per_m.data(), p.x, p.y, p.z, f.x, f.y, f.z);
  });
}

// The spring force on node i: its springs' forces, + where it is the first node, - where the
// second. adj_spring holds e for the first and ~e (negative) for the second, so one load gives
// both. Two sets of sums halve the chain of dependent additions (a node has about ten springs).
inline void gather(const Simulation& s, int32_t i, const ConstCols& fs, double& fx, double& fy,
                   double& fz) {
  const int32_t* __restrict signed_spring = s.adj_signed.data();
  const double *__restrict gx = fs.x, *__restrict gy = fs.y, *__restrict gz = fs.z;
  double ax = 0.0, ay = 0.0, az = 0.0, bx = 0.0, by = 0.0, bz = 0.0;
  int32_t a = s.adj_offsets[i];
  const int32_t end = s.adj_offsets[i + 1];
  for (; a + 1 < end; a += 2) {
    const int32_t c0 = signed_spring[a], c1 = signed_spring[a + 1];
    const int32_t e0 = spring_of(c0), e1 = spring_of(c1);
    const double s0 = end_sign(c0), s1 = end_sign(c1);
    ax += s0 * gx[e0], ay += s0 * gy[e0], az += s0 * gz[e0];
    bx += s1 * gx[e1], by += s1 * gy[e1], bz += s1 * gz[e1];
  }
  if (a < end) {
    const int32_t c = signed_spring[a], e = spring_of(c);
    const double sg = end_sign(c);
    ax += sg * gx[e], ay += sg * gy[e], az += sg * gz[e];
  }
  fx += ax + bx, fy += ay + by, fz += az + bz;
}

// The force on movable node i (mN): its springs' (gathered from fs), the tool's, gravity, its
// anchor spring, the volume term's pressure (from update_volume_term) and, if damped,
// -(gamma + alpha m) v. Backward Euler puts the damping into its matrix instead.
inline void node_force(const Simulation& s, int32_t i, const ConstCols& fs, const ConstCols& fe,
                       const ConstCols& x, const ConstCols& v, bool damped, double& fx,
                       double& fy, double& fz) {
  const Material& mat = s.material;
  const Eigen::MatrixX3d& X = s.model->X;
  const double m = s.mass_kg[i], anchor = mat.anchor_stiffness_n_per_m;
  const Eigen::Vector3d& g = mat.gravity_mm_per_s2;
  fx = fe.x[i] + m * g.x() - anchor * (x.x[i] - X(i, 0));
  fy = fe.y[i] + m * g.y() - anchor * (x.y[i] - X(i, 1));
  fz = fe.z[i] + m * g.z() - anchor * (x.z[i] - X(i, 2));
  if (damped) {
    const double damp = mat.damping_kg_per_s + mat.mass_damping_per_s * m;
    fx -= damp * v.x[i], fy -= damp * v.y[i], fz -= damp * v.z[i];
  }
  if (mat.volume_stiffness_kpa > 0.0) {
    // The pressures on either side of the node's layer, across its share of the layer's area.
    const double jump = s.pressure_jump_kpa[s.model->layer_of[i]];
    const Eigen::MatrixX3d& g = s.volume_gradient;
    fx -= jump * g(i, 0), fy -= jump * g(i, 1), fz -= jump * g(i, 2);
  }
  gather(s, i, fs, fx, fy, fz);
}

// Semi-implicit (symplectic) Euler, the paper's: v += dt a(x, v); x += dt v. Two passes: the
// springs, then each movable node gathers its forces, integrates, checks and measures itself.
// With save, the movable nodes' old state goes to x_prev/v_prev first (the step's rollback).
Measured semi_implicit_euler(Simulation& s, double dt, bool save) {
  const int T = threads_for(s);
  if (s.material.volume_stiffness_kpa > 0.0) update_volume_term(s, s.x, T);
  const bool dense = s.active_springs.size() == s.model->springs.size();
  spring_pass(s, s.x, dense ? nullptr : s.active_springs.data(),
              static_cast<int64_t>(s.active_springs.size()), s.spring_force, T);
  const ConstCols fs(s.spring_force), fe(s.f_ext), x(s.x), v(s.v);
  NodeState state(s);
  Partials part;
  for_slices(static_cast<int64_t>(s.active_nodes.size()), T,
             [&](int64_t begin, int64_t end, int t) {
               Partial acc;
               for (int64_t q = begin; q < end; ++q) {
                 const int32_t i = s.active_nodes[q];
                 double fx, fy, fz;
                 node_force(s, i, fs, fe, x, v, /*damped=*/true, fx, fy, fz);
                 const double h_m = dt / s.mass_kg[i];
                 finish_node(s, state, i, dt, save, v.x[i] + h_m * fx, v.y[i] + h_m * fy,
                             v.z[i] + h_m * fz, acc);
               }
               part[t] = acc;
             });
  return combine(part, T);
}

// y = (M + h gamma + h^2 K) p on the movable nodes, K the spring (and anchor) stiffness matrix
// linearised at the current positions (directions and max(0, 1 - L/l) cached in s.dir, in single
// precision: the linearisation only steers the solve, and half the bytes speed the product): per
// spring k [u u^T + alpha (I - u u^T)]. Returns p . y (CG's curvature) summed in thread order.
double system_product(const Simulation& s, double h, const Eigen::MatrixX3d& pm,
                      Eigen::MatrixX3d& ym, int T) {
  const double h2 = h * h, anchor = s.material.anchor_stiffness_n_per_m;
  const double damp = h * s.material.damping_kg_per_s, mass_damp = h * s.material.mass_damping_per_s;
  const ConstCols p(pm);
  Cols y(ym);
  const float* dir = s.dir.data();  // per spring: ux, uy, uz, alpha
  // The volume term's stiffness is one rank-one matrix per region: two passes instead of a
  // dense matrix (its pressure-times-curvature part is left out, keeping the matrix positive).
  const bool volume = s.material.volume_stiffness_kpa > 0.0;
  std::array<double, kMaxLayers> vm{};
  if (volume) volume_multipliers(s, pm, T, vm.data());
  const ConstCols g(s.volume_gradient);
  const int32_t* layer_of = s.model->layer_of.data();
  Partials part;
  for_slices(static_cast<int64_t>(s.active_nodes.size()), T,
             [&](int64_t begin, int64_t end, int t) {
               double pap = 0.0;
               for (int64_t q = begin; q < end; ++q) {
                 const int32_t i = s.active_nodes[q];
                 const double pix = p.x[i], piy = p.y[i], piz = p.z[i];
                 double kx = anchor * pix, ky = anchor * piy, kz = anchor * piz;
                 for (int32_t a = s.adj_offsets[i]; a < s.adj_offsets[i + 1]; ++a) {
                   const int32_t e = s.adj_spring[a], j = s.adj_other[a];
                   const double dx = pix - p.x[j], dy = piy - p.y[j], dz = piz - p.z[j];
                   const float* u = dir + 4 * static_cast<int64_t>(e);
                   const double cx = u[0], cy = u[1], cz = u[2];
                   const double along = cx * dx + cy * dy + cz * dz;
                   const double k = s.stiffness_n_per_m[e], ka = k * u[3];
                   // k (along u + alpha (d - along u)) = k alpha d + k (1 - alpha) along u
                   const double ku = (k - ka) * along;
                   kx += ka * dx + ku * cx, ky += ka * dy + ku * cy, kz += ka * dz + ku * cz;
                 }
                 if (volume) {
                   const double c = vm[layer_of[i]];
                   kx += c * g.x[i], ky += c * g.y[i], kz += c * g.z[i];
                 }
                 const double md = s.mass_kg[i] * (1.0 + mass_damp) + damp;
                 const double yx = md * pix + h2 * kx, yy = md * piy + h2 * ky,
                              yz = md * piz + h2 * kz;
                 y.x[i] = yx, y.y[i] = yy, y.z[i] = yz;
                 pap += pix * yx + piy * yy + piz * yz;
               }
               part[t].a = pap;
             });
  double sum = 0.0;
  for (int t = 0; t < T; ++t) sum += part[t].a;
  return sum;
}

// Backward Euler, linearised once per step (Baraff-Witkin), solved for the new velocity:
//   (M + h gamma + h^2 K) v1 = M v0 + h f0(x0),   x1 = x0 + h v1,
// f0 every force but damping, K the spring (and anchor) stiffness at x0. K's geometric term is
// clamped at max(0, 1 - L/l) so the matrix stays positive definite under compression and CG
// applies. Jacobi-preconditioned, warm-started from v0 plus the last step's change (a smooth
// motion changes its velocity by about the same each step). One product for the start residual
// and one per CG iteration.
Measured implicit_euler(Simulation& s, double h, bool save, int32_t& iterations) {
  const int T = threads_for(s);
  const Springs& sp = s.model->springs;
  const Material& mat = s.material;
  const double h2 = h * h, damp_h = h * mat.damping_kg_per_s;
  const double mass_damp_h = h * mat.mass_damping_per_s;
  const double anchor = mat.anchor_stiffness_n_per_m;
  const auto nodes = static_cast<int64_t>(s.active_nodes.size());
  const bool volume = mat.volume_stiffness_kpa > 0.0;
  if (volume) update_volume_term(s, s.x, T);

  // 1. Springs: the force on the first node, and the linearisation (direction, 1 - L/l).
  {
    const ConstCols x(s.x);
    Cols f(s.spring_force);
    float* dir = s.dir.data();
    for_slices(static_cast<int64_t>(s.active_springs.size()), T,
               [&](int64_t begin, int64_t end, int) {
                 for (int64_t q = begin; q < end; ++q) {
                   const int32_t e = s.active_springs[q], a = sp.i[e], b = sp.j[e];
                   const double dx = x.x[b] - x.x[a], dy = x.y[b] - x.y[a], dz = x.z[b] - x.z[a];
                   const double l = std::max(std::sqrt(dx * dx + dy * dy + dz * dz), 1e-12);
                   const double t = s.stiffness_n_per_m[e] * (l - sp.rest_length_mm[e]) / l;
                   f.x[e] = t * dx, f.y[e] = t * dy, f.z[e] = t * dz;
                   float* u = dir + 4 * static_cast<int64_t>(e);
                   u[0] = static_cast<float>(dx / l), u[1] = static_cast<float>(dy / l);
                   u[2] = static_cast<float>(dz / l);
                   u[3] = static_cast<float>(std::max(0.0, 1.0 - sp.rest_length_mm[e] / l));
                 }
               });
  }

  // 2. The warm start w = v0 + (last step's v1 - v0), into dv (which holds the solution from
  //    here on; rows of held nodes stay 0 there and in v).
  {
    Cols w(s.dv);
    const ConstCols v(s.v);
    for_slices(nodes, T, [&](int64_t begin, int64_t end, int) {
      for (int64_t q = begin; q < end; ++q) {
        const int32_t i = s.active_nodes[q];
        w.x[i] += v.x[i], w.y[i] += v.y[i], w.z[i] += v.z[i];
      }
    });
  }

  // 3. Per node: b = M v0 + h f0, r = b - A w, the Jacobi diagonal, z = r / diag, p = z.
  Partials part;
  std::array<double, kMaxLayers> vm{}, vd{};  // the volume term along w; its diagonal factor
  if (volume) {
    volume_multipliers(s, s.dv, T, vm.data());
    for (size_t k = 0; k < s.model->layers.size(); ++k)
      vd[k] = region_stiffness(s, k) + (k > 0 ? region_stiffness(s, k - 1) : 0.0);
  }
  {
    const ConstCols g(s.volume_gradient);
    const ConstCols fs(s.spring_force), fe(s.f_ext), v(s.v), x(s.x), w(s.dv);
    Cols r(s.r), z(s.z), pp(s.p), dg(s.diag);
    const float* dir = s.dir.data();
    for_slices(nodes, T, [&](int64_t begin, int64_t end, int t) {
      Partial acc;  // a: |b|^2, b: r.z, c: |r|^2
      for (int64_t q = begin; q < end; ++q) {
        const int32_t i = s.active_nodes[q];
        const double m = s.mass_kg[i];
        double fx, fy, fz;
        node_force(s, i, fs, fe, x, v, /*damped=*/false, fx, fy, fz);
        const double wx = w.x[i], wy = w.y[i], wz = w.z[i];
        double kx = anchor * wx, ky = anchor * wy, kz = anchor * wz;
        double d0 = anchor, d1 = anchor, d2 = anchor;
        for (int32_t a = s.adj_offsets[i]; a < s.adj_offsets[i + 1]; ++a) {
          const int32_t e = s.adj_spring[a], j = s.adj_other[a];
          const float* u = dir + 4 * static_cast<int64_t>(e);
          const double k = s.stiffness_n_per_m[e], ka = k * u[3], kb = k - ka;
          const double cx = u[0], cy = u[1], cz = u[2];
          const double dx = wx - w.x[j], dy = wy - w.y[j], dz = wz - w.z[j];
          const double along = kb * (cx * dx + cy * dy + cz * dz);
          kx += ka * dx + along * cx, ky += ka * dy + along * cy, kz += ka * dz + along * cz;
          d0 += ka + kb * cx * cx, d1 += ka + kb * cy * cy, d2 += ka + kb * cz * cz;
        }
        if (volume) {
          const int32_t k = s.model->layer_of[i];
          const double gx = g.x[i], gy = g.y[i], gz = g.z[i];
          kx += vm[k] * gx, ky += vm[k] * gy, kz += vm[k] * gz;
          d0 += vd[k] * gx * gx, d1 += vd[k] * gy * gy, d2 += vd[k] * gz * gz;
        }
        const double md = m * (1.0 + mass_damp_h) + damp_h;
        const double bx = m * v.x[i] + h * fx, by = m * v.y[i] + h * fy, bz = m * v.z[i] + h * fz;
        const double rx = bx - md * wx - h2 * kx, ry = by - md * wy - h2 * ky,
                     rz = bz - md * wz - h2 * kz;
        const double gx = md + h2 * d0, gy = md + h2 * d1, gz = md + h2 * d2;
        dg.x[i] = gx, dg.y[i] = gy, dg.z[i] = gz;
        r.x[i] = rx, r.y[i] = ry, r.z[i] = rz;
        const double zx = rx / gx, zy = ry / gy, zz = rz / gz;
        z.x[i] = zx, z.y[i] = zy, z.z[i] = zz;
        pp.x[i] = zx, pp.y[i] = zy, pp.z[i] = zz;
        acc.a += bx * bx + by * by + bz * bz;
        acc.b += rx * zx + ry * zy + rz * zz;
        acc.c += rx * rx + ry * ry + rz * rz;
      }
      part[t] = acc;
    });
  }
  double b2 = 0.0, rz = 0.0, r2 = 0.0;
  for (int t = 0; t < T; ++t) b2 += part[t].a, rz += part[t].b, r2 += part[t].c;
  // A load so large that |b|^2 overflows would stop CG before its first iteration and pass for
  // "no motion": it is a failed step (nothing has been written yet).
  if (!std::isfinite(b2) || !std::isfinite(rz)) {
    Measured failed;
    failed.ok = false;
    return failed;
  }

  // 4. Conjugate gradients on v1 (in dv).
  const double stop2 = s.options.cg_tolerance * s.options.cg_tolerance * b2;
  int32_t it = 0;
  if (b2 == 0.0) {
    // No force and no motion: the answer is v1 = 0, whatever the warm start said.
    for (int32_t i : s.active_nodes) s.dv.row(i).setZero();
  } else {
    for (; it < s.options.cg_max_iterations && r2 > stop2; ++it) {
      const double pap = system_product(s, h, s.p, s.y, T);
      if (!(pap > 0.0)) break;
      const double alpha = rz / pap;
      Cols dv(s.dv), r(s.r), z(s.z);
      const ConstCols pp(s.p), y(s.y), dg(s.diag);
      for_slices(nodes, T, [&](int64_t begin, int64_t end, int t) {
        Partial acc;  // b: r.z, c: |r|^2
        for (int64_t q = begin; q < end; ++q) {
          const int32_t i = s.active_nodes[q];
          dv.x[i] += alpha * pp.x[i], dv.y[i] += alpha * pp.y[i], dv.z[i] += alpha * pp.z[i];
          const double rx = r.x[i] - alpha * y.x[i], ry = r.y[i] - alpha * y.y[i],
                       rz_ = r.z[i] - alpha * y.z[i];
          r.x[i] = rx, r.y[i] = ry, r.z[i] = rz_;
          const double zx = rx / dg.x[i], zy = ry / dg.y[i], zz = rz_ / dg.z[i];
          z.x[i] = zx, z.y[i] = zy, z.z[i] = zz;
          acc.b += rx * zx + ry * zy + rz_ * zz;
          acc.c += rx * rx + ry * ry + rz_ * rz_;
        }
        part[t] = acc;
      });
      double rz_new = 0.0;
      r2 = 0.0;
      for (int t = 0; t < T; ++t) rz_new += part[t].b, r2 += part[t].c;
      const double beta = rz_new / rz;
      rz = rz_new;
      if (r2 <= stop2) {
        ++it;
        break;
      }
      Cols pw(s.p);
      const ConstCols zc(s.z);
      for_slices(nodes, T, [&](int64_t begin, int64_t end, int) {
        for (int64_t q = begin; q < end; ++q) {
          const int32_t i = s.active_nodes[q];
          pw.x[i] = zc.x[i] + beta * pw.x[i], pw.y[i] = zc.y[i] + beta * pw.y[i],
          pw.z[i] = zc.z[i] + beta * pw.z[i];
        }
      });
    }
  }
  iterations = it;

  // 5. Update, check and measure; dv keeps this step's change for the next warm start.
  NodeState state(s);
  Cols dv(s.dv);
  const ConstCols v(s.v);
  for_slices(nodes, T, [&](int64_t begin, int64_t end, int t) {
    Partial acc;
    for (int64_t q = begin; q < end; ++q) {
      const int32_t i = s.active_nodes[q];
      const double vx = dv.x[i], vy = dv.y[i], vz = dv.z[i];
      dv.x[i] = vx - v.x[i], dv.y[i] = vy - v.y[i], dv.z[i] = vz - v.z[i];
      finish_node(s, state, i, h, save, vx, vy, vz, acc);
    }
    part[t] = acc;
  });
  return combine(part, T);
}

Measured measure(const Simulation& s);

Measured advance(Simulation& s, Integrator integrator, double h, bool save, int32_t& cg) {
  switch (integrator) {
    case Integrator::kSemiImplicitEuler: {
      // Beyond the stability limit: equal substeps below it (the rollback saves the start).
      if (s.explicit_limit_version != s.setup_version) {
        s.explicit_limit_s = explicit_dt_limit(s);
        s.explicit_limit_version = s.setup_version;
      }
      const int64_t n = explicit_substeps(h, s.explicit_limit_s);
      Measured m = semi_implicit_euler(s, h / static_cast<double>(n), save);
      for (int64_t k = 1; k < n && m.ok; ++k)
        m = semi_implicit_euler(s, h / static_cast<double>(n), false);
      return n > 1 && m.ok ? measure(s) : m;
    }
    case Integrator::kProjective:
      return projective_step(s, h, save);
    default:
      return implicit_euler(s, h, save, cg);
  }
}

// The movable nodes back to their state before the step.
void roll_back(Simulation& s) {
  for (int32_t i : s.active_nodes) {
    s.x.row(i) = s.x_prev.row(i);
    s.v.row(i) = s.v_prev.row(i);
  }
}

// Measurements of the movable nodes against x_prev (after a recovered step, whose parts each
// measured only themselves).
Measured measure(const Simulation& s) {
  Partial acc;
  for (int32_t i : s.active_nodes)
    account(s, i, s.x_prev(i, 0), s.x_prev(i, 1), s.x_prev(i, 2), s.x(i, 0), s.x(i, 1), s.x(i, 2),
            s.v(i, 0), s.v(i, 1), s.v(i, 2), acc);
  Partials part;
  part[0] = acc;
  return combine(part, 1);
}

// Rebuilds what a step visits and what it caches about the nodes that stay put. O(model); runs
// only when the movable set changes.
void refresh(Simulation& s) {
  ++s.setup_version;
  const Model& m = *s.model;
  const int32_t n = m.node_count();
  s.active_nodes.clear();
  double frozen2 = 0.0;
  for (int32_t i = 0; i < n; ++i) {
    if (s.movable[i]) {
      s.active_nodes.push_back(i);
      continue;
    }
    s.v.row(i).setZero();
    for (Eigen::MatrixX3d* w : {&s.r, &s.z, &s.p, &s.dv}) w->row(i).setZero();
    frozen2 = std::max(frozen2, (s.x.row(i) - m.X.row(i)).squaredNorm());
  }
  s.frozen_max_displacement_mm = std::sqrt(frozen2);
  const Springs& sp = m.springs;
  s.active_springs.clear();
  for (size_t e = 0; e < sp.size(); ++e)
    if (s.movable[sp.i[e]] || s.movable[sp.j[e]]) s.active_springs.push_back(static_cast<int32_t>(e));
  s.layer_triangles.resize(m.layers.size());
  s.frozen_layer_volume6_mm3.resize(m.layers.size());
  std::vector<int32_t> frozen;
  for (size_t k = 0; k < m.layers.size(); ++k) {
    const Eigen::MatrixX3i& F = m.layers[k].F;
    std::vector<int32_t>& active = s.layer_triangles[k];
    active.clear();
    frozen.clear();
    for (Eigen::Index t = 0; t < F.rows(); ++t)
      (s.movable[F(t, 0)] || s.movable[F(t, 1)] || s.movable[F(t, 2)] ? active : frozen)
          .push_back(static_cast<int32_t>(t));
    s.frozen_layer_volume6_mm3[k] =
        volume6(F, s.x, frozen.data(), static_cast<int64_t>(frozen.size()), 1);
  }
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
  if (!non_negative(m.mass_damping_per_s))
    throw invalid_input("material.mass_damping", "must be >= 0 1/s");
  if (!non_negative(m.volume_stiffness_kpa))
    throw invalid_input("material.volume_stiffness", "must be >= 0 kPa (0 = off)");
  if (!m.gravity_mm_per_s2.allFinite()) throw invalid_input("material.gravity", "must be finite");
  if (!positive(o.dt_s)) throw invalid_input("solver.dt", "must be > 0 s");
  if (!positive(o.threshold_mm)) throw invalid_input("solver.threshold", "must be > 0 mm");
  if (o.max_steps < 1) throw invalid_input("solver.max_steps", "must be >= 1");
  if (o.cg_max_iterations < 1) throw invalid_input("solver.cg_max_iterations", "must be >= 1");
  if (o.projective_iterations < 1)
    throw invalid_input("solver.projective_iterations", "must be >= 1");
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
  s.adj_signed.resize(s.adj_other.size());
  std::vector<int32_t> fill(s.adj_offsets.begin(), s.adj_offsets.end() - 1);
  for (size_t e = 0; e < sp.size(); ++e) {
    const int32_t a = sp.i[e], b = sp.j[e], ei = static_cast<int32_t>(e);
    s.adj_signed[fill[a]] = ei, s.adj_signed[fill[b]] = ~ei;
    s.adj_other[fill[a]] = b, s.adj_spring[fill[a]++] = ei;
    s.adj_other[fill[b]] = a, s.adj_spring[fill[b]++] = ei;
  }
  s.rest_layer_volume_mm3.resize(model.layers.size());
  for (int32_t k = 0; k < model.layer_count(); ++k)
    s.rest_layer_volume_mm3[k] = layer_volume(model, model.X, k);
  s.rest_skin_volume_mm3 = s.rest_layer_volume_mm3.at(0);
  if (material.volume_stiffness_kpa > 0.0) setup_volume_term(s);
  s.blowup_limit_mm =
      100.0 * (model.X.colwise().maxCoeff() - model.X.colwise().minCoeff()).norm() + 1.0;
  for (Eigen::MatrixX3d* m : {&s.x_prev, &s.v_prev, &s.r, &s.p, &s.z, &s.y, &s.dv})
    *m = Eigen::MatrixX3d::Zero(n, 3);
  s.diag = Eigen::MatrixX3d::Ones(n, 3);
  const auto springs = static_cast<Eigen::Index>(sp.size());
  s.spring_force = Eigen::MatrixX3d::Zero(springs, 3);
  s.dir = Eigen::Matrix<float, Eigen::Dynamic, 4, Eigen::RowMajor>::Zero(springs, 4);
  refresh(s);
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
  const bool to_global = options.mode == Mode::kGlobal && s.options.mode != Mode::kGlobal;
  if (to_global)
    for (size_t i = 0; i < n; ++i) s.movable[i] = !s.fixed[i];
  s.material = material;
  s.options = options;
  if (material.volume_stiffness_kpa > 0.0 && s.corner_offsets.empty()) setup_volume_term(s);
  ++s.setup_version;
  if (to_global) refresh(s);
}

namespace {
void check_nodes(const Simulation& s, const std::vector<int32_t>& nodes) {
  for (int32_t i : nodes)
    if (i < 0 || i >= s.model->node_count())
      throw invalid_input("fixed nodes", "node " + std::to_string(i) + " is not in the model (0.." +
                                             std::to_string(s.model->node_count() - 1) + ")");
}
}  // namespace

void fix_nodes(Simulation& s, const std::vector<int32_t>& nodes) {
  check_nodes(s, nodes);
  for (int32_t i : nodes) {
    s.fixed[i] = 1;
    s.movable[i] = 0;
    s.x.row(i) = s.model->X.row(i);
    s.v.row(i).setZero();
  }
  refresh(s);
}

void hold_nodes(Simulation& s, const std::vector<int32_t>& nodes,
                const Eigen::MatrixX3d& positions) {
  if (positions.rows() != static_cast<Eigen::Index>(nodes.size()))
    throw invalid_input("held nodes", "need one position per node");
  if (!positions.allFinite()) throw invalid_input("held nodes", "positions must be finite");
  fix_nodes(s, nodes);  // checks the indices, stops the nodes
  for (size_t k = 0; k < nodes.size(); ++k) s.x.row(nodes[k]) = positions.row(static_cast<Eigen::Index>(k));
  refresh(s);  // the caches of what stays put see the new positions
}

void release_nodes(Simulation& s, const std::vector<int32_t>& nodes) {
  check_nodes(s, nodes);
  for (int32_t i : nodes) {
    s.fixed[i] = 0;
    // In local mode only the nodes a tool reaches move; a released node joins them, so that
    // it can return to rest.
    s.movable[i] = 1;
    s.v.row(i).setZero();
  }
  refresh(s);
}

void reset(Simulation& s) {
  s.x = s.model->X;
  s.v.setZero();
  s.dv.setZero();
  s.time_s = 0.0;
  refresh(s);
}

SimState capture_state(const Simulation& s) {
  return SimState{s.x, s.v, s.f_ext, s.dv, s.time_s, s.steps, s.recoveries, s.fixed, s.movable};
}

void restore_state(Simulation& s, const SimState& st) {
  const Eigen::Index n = s.model->node_count();
  const auto un = static_cast<size_t>(n);
  for (const Eigen::MatrixX3d* m : {&st.x, &st.v, &st.f_ext, &st.dv})
    if (m->rows() != n) throw invalid_input("simulation state", "has " + std::to_string(m->rows()) +
                                                                    " nodes, the model " +
                                                                    std::to_string(n));
  if (st.fixed.size() != un || st.movable.size() != un)
    throw invalid_input("simulation state", "node flags do not match the model's node count");
  if (!st.x.allFinite() || !st.v.allFinite() || !st.f_ext.allFinite() || !st.dv.allFinite())
    throw invalid_input("simulation state", "holds a value that is not finite");
  for (size_t i = 0; i < un; ++i)
    if (st.fixed[i] > 1 || st.movable[i] > 1 || (st.fixed[i] && st.movable[i]))
      throw invalid_input("simulation state", "node " + std::to_string(i) +
                                                  ": fixed and movable flags are not 0/1 or both set");
  if (!std::isfinite(st.time_s) || st.time_s < 0.0 || st.steps < 0 || st.recoveries < 0)
    throw invalid_input("simulation state", "time, step or recovery count out of range");
  s.x = st.x;
  s.v = st.v;
  s.f_ext = st.f_ext;
  s.fixed = st.fixed;
  s.movable = st.movable;
  s.time_s = st.time_s;
  s.steps = st.steps;
  s.recoveries = st.recoveries;
  refresh(s);  // the active lists and frozen caches; it zeroes dv of nodes that do not move
  s.dv = st.dv;
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
  refresh(s);
}

void spring_forces(Simulation& s, const Eigen::MatrixX3d& x, Eigen::MatrixX3d& f) {
  // Every spring, not only the active ones: this is the whole model's force at any x.
  const auto springs = static_cast<int64_t>(s.model->springs.size());
  const int T = threads_for_springs(springs);
  spring_pass(s, x, nullptr, springs, s.spring_force, T);
  const ConstCols c(s.spring_force);
  for_slices(x.rows(), T, [&](int64_t begin, int64_t end, int) {
    for (int64_t i = begin; i < end; ++i) {
      double fx = 0.0, fy = 0.0, fz = 0.0;
      gather(s, static_cast<int32_t>(i), c, fx, fy, fz);
      f(i, 0) += fx, f(i, 1) += fy, f(i, 2) += fz;
    }
  });
}

void implicit_system_product(const Simulation& s, double h, const Eigen::MatrixX3d& p,
                             Eigen::MatrixX3d& y) {
  for (int32_t i = 0; i < s.model->node_count(); ++i)
    if (!s.movable[i]) y.row(i).setZero();
  system_product(s, h, p, y, threads_for(s));
}

double layer_volume(const Model& model, const Eigen::MatrixX3d& x, int32_t layer) {
  const Eigen::MatrixX3i& F = model.layers.at(static_cast<size_t>(layer)).F;
  return volume6(F, x, nullptr, F.rows(), 1) / 6.0;
}

double elastic_energy(const Simulation& s, const Eigen::MatrixX3d& x) {
  const double anchor = 0.5 * s.material.anchor_stiffness_n_per_m *
                        (x - s.model->X).rowwise().squaredNorm().sum();  // N/m mm^2 = 1e-6 J
  const double volume =
      s.material.volume_stiffness_kpa > 0.0 ? volume_energy(s, x) : 0.0;  // kPa mm^3 = 1e-6 J
  return spring_energy(s, x) + (anchor + volume) * kJoulesPerKgMm2PerS2;
}

double explicit_dt_limit(const Simulation& s) {
  const Model& m = *s.model;
  std::vector<double> row(static_cast<size_t>(m.node_count()), s.material.anchor_stiffness_n_per_m);
  const Springs& sp = m.springs;
  for (size_t e = 0; e < sp.size(); ++e) {
    row[sp.i[e]] += 2.0 * s.stiffness_n_per_m[e];
    row[sp.j[e]] += 2.0 * s.stiffness_n_per_m[e];
  }
  if (s.material.volume_stiffness_kpa > 0.0) add_volume_stiffness_rows(s, row);
  double limit = std::numeric_limits<double>::infinity();
  for (int32_t i = 0; i < m.node_count(); ++i) {
    if (s.fixed[i] || row[i] <= 0.0) continue;
    const double w2 = row[i] / s.mass_kg[i];
    const double c = s.material.damping_kg_per_s / s.mass_kg[i] + s.material.mass_damping_per_s;
    limit = std::min(limit, (std::sqrt(c * c + 4.0 * w2) - c) / w2);  // root of w2 h^2 + 2ch = 4
  }
  return limit;
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
  const double h = s.options.dt_s;
  const Integrator integrator = s.options.integrator;
  Measured m = advance(s, integrator, h, /*save=*/true, st.cg_iterations);
  if (!m.ok) {
    // Roll back and redo: two half steps of the same integrator, then backward Euler (stable at
    // any dt); if even that fails, stop the motion: never let a NaN out.
    st.recovered = true;
    ++s.recoveries;
    roll_back(s);
    if (integrator == Integrator::kSemiImplicitEuler) {
      m = semi_implicit_euler(s, 0.5 * h, false);
      if (m.ok) m = semi_implicit_euler(s, 0.5 * h, false);
    }
    if (!m.ok || integrator != Integrator::kSemiImplicitEuler) {
      roll_back(s);
      s.dv.setZero();  // the failed solve's answer is no guess for the next
      m = implicit_euler(s, h, false, st.cg_iterations);
    }
    if (!m.ok) {
      roll_back(s);
      for (int32_t i : s.active_nodes) s.v.row(i).setZero();
      s.dv.setZero();
      st.failed = true;
    }
    m = measure(s);
  }
  s.time_s += h;
  ++s.steps;

  st.max_move_mm = std::sqrt(m.move2);
  st.max_displacement_mm = std::max(std::sqrt(m.disp2), s.frozen_max_displacement_mm);
  st.kinetic_energy_j = m.ke * kJoulesPerKgMm2PerS2;
  const auto tris = static_cast<int64_t>(s.layer_triangles[0].size());
  st.skin_volume_mm3 = layer_volume_now(s, s.x, 0, tris >= 4 * kParallelSprings ? threads_for(s) : 1);
  st.volume_change_pct =
      100.0 * (st.skin_volume_mm3 - s.rest_skin_volume_mm3) / s.rest_skin_volume_mm3;
  st.converged = !st.failed && st.max_move_mm < s.options.threshold_mm;
  st.step_us =
      std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
  return st;
}

StepStats run_to_convergence(Simulation& s, int64_t quiet_steps) {
  StepStats st;
  int64_t quiet = 0;
  for (int64_t k = 0; k < s.options.max_steps; ++k) {
    st = step(s);
    if (st.failed) break;  // held still by force, not at rest
    quiet = st.converged ? quiet + 1 : 0;
    if (quiet >= std::max<int64_t>(1, quiet_steps)) return st;
  }
  st.converged = false;
  return st;
}

}  // namespace lamina::sim
