// Backward Euler, linearised once per step (Baraff-Witkin), solved for the new velocity:
//   (M + h gamma + h^2 K) v1 = M v0 + h f0(x0),   x1 = x0 + h v1,
// f0 every force but damping, K the stiffness of the springs, the tetrahedra, the support and
// the volume term at x0. The springs' geometric term is clamped at max(0, 1 - L/l), and the
// volume terms keep only their Gauss-Newton part, so the matrix stays positive definite under
// any deformation and conjugate gradients apply. Preconditioned by Jacobi or by multigrid
// (preconditioner.h), warm-started from v0
// plus the last step's change (a smooth motion changes its velocity by about the same each
// step). The cost is bounded: one product for the start residual and one per CG iteration (a
// multigrid V-cycle adds two), at most SolverOptions::cg_max_iterations.
#include <array>
#include <chrono>

#include "force_terms.h"
#include "lamina/core/log.h"
#include "preconditioner.h"
#include "spring_lanes_product.h"

namespace lamina::sim::detail {
namespace {

using Clock = std::chrono::steady_clock;

// (K p)_i of the support and the volume term between layers (from its per-layer multipliers),
// added to the springs' or the tetrahedra's k.
inline void other_stiffness(const Solver& s, int32_t i, const ConstCols& p, const double* vm,
                            const double* k, double& kx, double& ky, double& kz) {
  const double ks = s.support.stiffness_n_per_m[i];
  kx = k[0] + ks * p.x[i], ky = k[1] + ks * p.y[i], kz = k[2] + ks * p.z[i];
  if (vm) {
    const int32_t layer = s.model->layer_of[i];
    if (layer >= 0) {
      const double c = vm[layer];
      kx += c * s.volume.gradient(i, 0), ky += c * s.volume.gradient(i, 1),
          kz += c * s.volume.gradient(i, 2);
    }
  }
}

}  // namespace

// y = (M + h gamma + h^2 K) p on the movable nodes. Returns p . y (CG's curvature) summed in
// thread order.
double system_product(Solver& s, double h, const Eigen::MatrixX3d& pm, Eigen::MatrixX3d& ym,
                      int T) {
  const double h2 = h * h;
  const double damp = h * s.material.damping_kg_per_s,
               mass_damp = h * s.material.mass_damping_per_s;
  const bool volume = s.material.volume_stiffness_kpa > 0.0;
  std::array<double, kMaxLayers> vm{};
  if (volume) volume_multipliers(s, pm, T, vm.data());
  if (s.tets.on && !s.tets.assembly.current) tet_product_pass(s, pm, T);
  const ConstCols p(pm);
  Cols y(ym);
  Partials part;
  for_spring_products<false>(
      s, pm, T, part, [&](int32_t i, const double* k, const double*, Partial& acc) {
        double kx, ky, kz;
        other_stiffness(s, i, p, volume ? vm.data() : nullptr, k, kx, ky, kz);
        const double md = s.mass_kg[i] * (1.0 + mass_damp) + damp;
        const double yx = md * p.x[i] + h2 * kx, yy = md * p.y[i] + h2 * ky,
                     yz = md * p.z[i] + h2 * kz;
        y.x[i] = yx, y.y[i] = yy, y.z[i] = yz;
        acc.a += p.x[i] * yx + p.y[i] * yy + p.z[i] * yz;
      });
  double sum = 0.0;
  for (int t = 0; t < T; ++t) sum += part[t].a;
  return sum;
}

namespace {

Measured failed_step() {
  Measured failed;
  failed.ok = false;
  return failed;
}

// The step for one preconditioner (preconditioner.h): a pointwise one is applied inside the
// passes that produce the residual, the multigrid after them.
// `indefinite` is set (and nothing of the step kept but its partial solution, as the next
// attempt's warm start) when a V-cycle gives r . z <= 0.
template <class Pre>
Measured implicit_euler_with(Simulation& sim, double h, bool save, int32_t& iterations,
                             StepProfile& profile, bool& indefinite) {
  constexpr bool kPointwise = Pre::kPointwise;
  Solver& s = sim.solver();
  const int T = threads_for(s);
  const Material& mat = s.material;
  const double h2 = h * h, damp_h = h * mat.damping_kg_per_s;
  const double mass_damp_h = h * mat.mass_damping_per_s;
  const auto nodes = static_cast<int64_t>(s.active_nodes.size());
  const bool volume = mat.volume_stiffness_kpa > 0.0;
  const bool lanes = product_lanes_apply(s);  // the springs' linearisation and products
  const auto t0 = Clock::now();

  // 1. The warm start w = v0 + (last step's v1 - v0), into dv (which holds the solution from
  //    here on; rows of held nodes stay 0 there and in v).
  {
    Cols w(s.dv);
    const ConstCols v(sim.v);
    for_slices(nodes, T, [&](int64_t begin, int64_t end, int) {
      for (int64_t q = begin; q < end; ++q) {
        const int32_t i = s.active_nodes[q];
        w.x[i] += v.x[i], w.y[i] += v.y[i], w.z[i] += v.z[i];
      }
    });
  }

  // 2. Forces at x0 and the linearisation: springs (direction, 1 - L/l), tetrahedra (with their
  //    share of K w in the same sweep), the volume term between layers.
  if (volume) update_volume_term(s, sim.x, T);
  if (s.tets.on) {
    tet_pass(s, sim.x, /*linearise=*/true, T, /*product_of=*/&s.dv);
    s.tets.assembly.current = false;
  } else if (lanes)
    linearise_lanes(s, sim.x, T);
  else
    spring_linearise(s, sim.x, T);
  const auto t1 = Clock::now();
  profile.forces_us += std::chrono::duration<double, std::micro>(t1 - t0).count();

  // 3. Per node: b = M v0 + h f0, r = b - A w, the Jacobi diagonal, z = r / diag, p = z.
  Partials part;
  std::array<double, kMaxLayers> vm{}, vd{};  // the volume term along w; its diagonal factor
  if (volume) {
    volume_multipliers(s, s.dv, T, vm.data());
    for (size_t k = 0; k < s.model->layers.size(); ++k)
      vd[k] = region_stiffness(s, k) + (k > 0 ? region_stiffness(s, k - 1) : 0.0);
  }
  {
    const ConstCols v(sim.v), w(s.dv);
    Cols r(s.r), z(s.z), pp(s.p), dg(s.diag);
    // acc.a: |b|^2, b: r.z (a pointwise preconditioner's), c: |r|^2, d: sum of m^2
    for_spring_products<true>(
        s, s.dv, T, part, [&](int32_t i, const double* k, const double* d, Partial& acc) {
          const double m = s.mass_kg[i];
          double fx, fy, fz;
          if (lanes) {
            node_force_but_elements(s, sim, i, /*damped=*/false, fx, fy, fz);
            gather_lane_force(s, i, fx, fy, fz);
          } else {
            node_force(s, sim, i, /*damped=*/false, fx, fy, fz);
          }
          double kx, ky, kz;
          other_stiffness(s, i, w, volume ? vm.data() : nullptr, k, kx, ky, kz);
          const double ks = s.support.stiffness_n_per_m[i];
          double d0 = d[0] + ks, d1 = d[1] + ks, d2 = d[2] + ks;
          if (volume) {
            const int32_t layer = s.model->layer_of[i];
            if (layer >= 0) {
              const double gx = s.volume.gradient(i, 0), gy = s.volume.gradient(i, 1),
                           gz = s.volume.gradient(i, 2);
              d0 += vd[layer] * gx * gx, d1 += vd[layer] * gy * gy, d2 += vd[layer] * gz * gz;
            }
          }
          const double md = m * (1.0 + mass_damp_h) + damp_h;
          const double bx = m * v.x[i] + h * fx, by = m * v.y[i] + h * fy, bz = m * v.z[i] + h * fz;
          const double rx = bx - md * w.x[i] - h2 * kx, ry = by - md * w.y[i] - h2 * ky,
                       rz = bz - md * w.z[i] - h2 * kz;
          const double gx = md + h2 * d0, gy = md + h2 * d1, gz = md + h2 * d2;
          dg.x[i] = gx, dg.y[i] = gy, dg.z[i] = gz;
          r.x[i] = rx, r.y[i] = ry, r.z[i] = rz;
          if constexpr (kPointwise) {
            const double zx = Pre::apply(rx, gx), zy = Pre::apply(ry, gy), zz = Pre::apply(rz, gz);
            z.x[i] = zx, z.y[i] = zy, z.z[i] = zz;
            pp.x[i] = zx, pp.y[i] = zy, pp.z[i] = zz;
            acc.b += rx * zx + ry * zy + rz * zz;
          }
          acc.a += bx * bx + by * by + bz * bz;
          acc.c += rx * rx + ry * ry + rz * rz;
          acc.d += m * m;
        });
  }
  double b2 = 0.0, rz = 0.0, r2 = 0.0, m2 = 0.0;
  for (int t = 0; t < T; ++t) b2 += part[t].a, rz += part[t].b, r2 += part[t].c, m2 += part[t].d;
  // A load so large that |b|^2 overflows would stop CG before its first iteration and pass for
  // "no motion": it is a failed step (nothing has been written yet).
  if (!std::isfinite(b2) || !std::isfinite(rz)) return failed_step();

  // 4. Conjugate gradients on v1 (in dv), to a residual of cg_tolerance |b|, or to one that
  //    stands for velocity errors of a thousandth of the rest speed: close to rest |b| itself
  //    is tiny, and a tolerance relative to it alone would chase round-off (a settling organ in
  //    the viewer took the iteration cap every step).
  const double floor_speed = 1e-3 * s.options.rest_speed_mm_per_s;
  const double stop2 = std::max(s.options.cg_tolerance * s.options.cg_tolerance * b2,
                                floor_speed * floor_speed * m2);
  int32_t it = 0;
  // A large model's step that iterates assembles the tetrahedra's stiffness first: each product
  // then streams node blocks (TetAssembly); one that converges at once never pays.
  const auto assemble = [&s, T] {
    TetAssembly& assembly = s.tets.assembly;
    if (assembly.on && !assembly.current) {
      assemble_tets(s, T);
      assembly.current = true;
    }
  };
  // The multigrid's z = B r, and p = z (only when CG iterates: a V-cycle costs two products).
  const auto precondition = [&] {
    assemble();
    const double rz_mg = apply_multigrid(s, h, T);
    Cols pw(s.p);
    const ConstCols zc(s.z);
    for_slices(nodes, T, [&](int64_t begin, int64_t end, int) {
      for (int64_t q = begin; q < end; ++q) {
        const int32_t i = s.active_nodes[q];
        pw.x[i] = zc.x[i], pw.y[i] = zc.y[i], pw.z[i] = zc.z[i];
      }
    });
    return rz_mg;
  };
  // The multigrid found not positive definite on r: give back dv as a velocity's warm start
  // (step 1 adds v0 again) for the Jacobi step that follows.
  const auto give_up = [&] {
    Cols w(s.dv);
    const ConstCols v(sim.v);
    for (int32_t i : s.active_nodes) w.x[i] -= v.x[i], w.y[i] -= v.y[i], w.z[i] -= v.z[i];
    iterations = it;
    indefinite = true;
    return failed_step();
  };
  if constexpr (!kPointwise) {
    if (b2 != 0.0 && r2 > stop2) {
      refresh_multigrid(s, h, T);
      rz = precondition();
      if (!std::isfinite(rz)) return failed_step();
      if (!(rz > 0.0)) return give_up();
    }
  }
  if (b2 == 0.0) {
    // No force and no motion: the answer is v1 = 0, whatever the warm start said.
    for (int32_t i : s.active_nodes) s.dv.row(i).setZero();
  } else {
    for (; it < s.options.cg_max_iterations && r2 > stop2; ++it) {
      assemble();
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
          if constexpr (kPointwise) {
            const double zx = Pre::apply(rx, dg.x[i]), zy = Pre::apply(ry, dg.y[i]),
                         zz = Pre::apply(rz_, dg.z[i]);
            z.x[i] = zx, z.y[i] = zy, z.z[i] = zz;
            acc.b += rx * zx + ry * zy + rz_ * zz;
          }
          acc.c += rx * rx + ry * ry + rz_ * rz_;
        }
        part[t] = acc;
      });
      double rz_new = 0.0;
      r2 = 0.0;
      for (int t = 0; t < T; ++t) rz_new += part[t].b, r2 += part[t].c;
      if (r2 <= stop2) {
        ++it;
        break;
      }
      if constexpr (!kPointwise) {
        rz_new = apply_multigrid(s, h, T);
        if (!(rz_new > 0.0)) return give_up();
      }
      const double beta = rz_new / rz;
      rz = rz_new;
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

  // 5. Update, check and measure; dv keeps this step's change for the next warm start. A step
  //    that would collapse a tetrahedron is shortened (inversion_limit.cpp).
  const double alpha = volume_keeping_fraction(s, sim.x, s.dv, h, T);
  NodeState state(sim, s);
  Cols dv(s.dv);
  const ConstCols v(sim.v);
  for_slices(nodes, T, [&](int64_t begin, int64_t end, int t) {
    Partial acc;
    for (int64_t q = begin; q < end; ++q) {
      const int32_t i = s.active_nodes[q];
      const double vx = alpha * dv.x[i], vy = alpha * dv.y[i], vz = alpha * dv.z[i];
      dv.x[i] = vx - v.x[i], dv.y[i] = vy - v.y[i], dv.z[i] = vz - v.z[i];
      finish_node(s, state, i, h, save, vx, vy, vz, acc);
    }
    part[t] = acc;
  });
  profile.integrate_us += std::chrono::duration<double, std::micro>(Clock::now() - t1).count();
  Measured m = combine(part, T);
  m.solved = b2 == 0.0 || r2 <= stop2;
  // Far above: a step ending at 2e-6 against 1e-6 (Jacobi at its iteration cap on a large
  // model) is the integrator's motion to 1e-6 of it; one at 1e-3 is not.
  m.stalled = b2 != 0.0 && r2 > 1e4 * stop2;
  m.residual = b2 > 0.0 ? std::sqrt(r2 / b2) : 0.0;
  m.step_fraction = alpha;
  return m;
}

}  // namespace

Measured implicit_euler(Simulation& sim, double h, bool save, int32_t& iterations,
                        StepProfile& profile) {
  Solver& s = sim.solver();
  bool indefinite = false;
  // At once unless dt, the material or the movable nodes changed.
  if (setup_multigrid(s, h)) {
    const Measured m =
        implicit_euler_with<MultigridPreconditioner>(sim, h, save, iterations, profile, indefinite);
    if (!indefinite) return m;
    // Never seen since the weight follows the step (refresh_multigrid); kept so that a case
    // nobody measured costs Jacobi's iterations instead of a wrong or failed step.
    if (s.multigrid->fallbacks++ == 0)
      log::warn(
          "implicit Euler: the multigrid was not positive definite after {} iterations; this "
          "step and any like it take Jacobi",
          iterations);
    int32_t more = 0;
    const Measured j =
        implicit_euler_with<JacobiPreconditioner>(sim, h, save, more, profile, indefinite);
    iterations += more;
    return j;
  }
  return implicit_euler_with<JacobiPreconditioner>(sim, h, save, iterations, profile, indefinite);
}

}  // namespace lamina::sim::detail
