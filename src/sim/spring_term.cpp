// The springs: the paper's Hooke springs along layer edges and links, or along the tetrahedra's
// edges. One pass computes each spring's force once (on its first node) into a per-spring
// buffer; each node then gathers its springs' forces with signs, so forces on the two ends are
// exactly opposite and no two threads ever write the same value.
#include <Eigen/Geometry>

#include "force_terms.h"
#include "solver.h"
#include "spring_kernel.h"

namespace lamina::sim::detail {

void setup_springs(Solver& s) {
  const Model& m = *s.model;
  const Springs& sp = m.springs;
  const int32_t n = m.node_count();
  SpringTerm& t = s.springs;
  t.adj_offsets.assign(static_cast<size_t>(n) + 1, 0);
  for (size_t e = 0; e < sp.size(); ++e) ++t.adj_offsets[sp.i[e] + 1], ++t.adj_offsets[sp.j[e] + 1];
  for (int32_t i = 0; i < n; ++i) t.adj_offsets[i + 1] += t.adj_offsets[i];
  t.adj_other.resize(static_cast<size_t>(t.adj_offsets[n]));
  t.adj_spring.resize(t.adj_other.size());
  t.adj_signed.resize(t.adj_other.size());
  std::vector<int32_t> fill(t.adj_offsets.begin(), t.adj_offsets.end() - 1);
  for (size_t e = 0; e < sp.size(); ++e) {
    const int32_t a = sp.i[e], b = sp.j[e], ei = static_cast<int32_t>(e);
    t.adj_signed[fill[a]] = ei, t.adj_signed[fill[b]] = ~ei;
    t.adj_other[fill[a]] = b, t.adj_spring[fill[a]++] = ei;
    t.adj_other[fill[b]] = a, t.adj_spring[fill[b]++] = ei;
  }
  const auto springs = static_cast<Eigen::Index>(sp.size());
  t.force = Eigen::MatrixX3d::Zero(springs, 3);
  t.dir = Eigen::Matrix<float, Eigen::Dynamic, 4, Eigen::RowMajor>::Zero(springs, 4);
}

void spring_pass(Solver& s, const Eigen::MatrixX3d& xm, int threads) {
  const Springs& sp = s.model->springs;
  const ConstCols p(xm);
  Cols f(s.springs.force);
  const bool dense = s.active_springs.size() == sp.size();
  const int32_t* list = dense ? nullptr : s.active_springs.data();
  for_slices(
      static_cast<int64_t>(s.active_springs.size()), threads, [&](int64_t begin, int64_t end, int) {
        spring_kernel<double>(begin, end, list, sp.i.data(), sp.j.data(), sp.rest_length_mm.data(),
                              s.springs.stiffness_n_per_m.data(), p.x, p.y, p.z, f.x, f.y, f.z);
      });
}

void refresh_compact_springs(Solver& s) {
  CompactSprings& c = s.compact;
  const Springs& sp = s.model->springs;
  // A quarter of the springs or more: the model's own arrays are streamed well enough.
  c.on = !s.tets.on && s.active_springs.size() * 4 < sp.size();
  if (!c.on) return;
  const auto count = s.active_springs.size();
  c.i.resize(count), c.j.resize(count), c.rest_mm.resize(count), c.k_n_per_m.resize(count);
  std::vector<int32_t> compact_of(sp.size(), -1);
  for (size_t q = 0; q < count; ++q) {
    const int32_t e = s.active_springs[q];
    compact_of[e] = static_cast<int32_t>(q);
    c.i[q] = sp.i[e], c.j[q] = sp.j[e];
    c.rest_mm[q] = sp.rest_length_mm[e];
    c.k_n_per_m[q] = s.springs.stiffness_n_per_m[e];
  }
  c.force = Eigen::MatrixX3d::Zero(static_cast<Eigen::Index>(count), 3);
  c.offsets.assign(1, 0);
  c.signed_spring.clear();
  const SpringTerm& t = s.springs;
  for (int32_t i : s.active_nodes) {  // every spring of a movable node is active
    for (int32_t a = t.adj_offsets[i]; a < t.adj_offsets[i + 1]; ++a) {
      const int32_t signed_e = t.adj_signed[a], q = compact_of[spring_of(signed_e)];
      c.signed_spring.push_back(signed_e < 0 ? ~q : q);
    }
    c.offsets.push_back(static_cast<int32_t>(c.signed_spring.size()));
  }
}

void compact_spring_pass(Solver& s, const Eigen::MatrixX3d& xm, int threads) {
  CompactSprings& c = s.compact;
  const ConstCols p(xm);
  Cols f(c.force);
  for_slices(static_cast<int64_t>(c.i.size()), threads, [&](int64_t begin, int64_t end, int) {
    spring_kernel<double>(begin, end, nullptr, c.i.data(), c.j.data(), c.rest_mm.data(),
                          c.k_n_per_m.data(), p.x, p.y, p.z, f.x, f.y, f.z);
  });
}

// The force on each spring's first node and its linearisation: unit direction and
// max(0, 1 - L/l).
void spring_linearise(Solver& s, const Eigen::MatrixX3d& xm, int threads) {
  const Springs& sp = s.model->springs;
  SpringTerm& t = s.springs;
  const ConstCols x(xm);
  Cols f(t.force);
  float* dir = t.dir.data();
  for_slices(static_cast<int64_t>(s.active_springs.size()), threads,
             [&](int64_t begin, int64_t end, int) {
               for (int64_t q = begin; q < end; ++q) {
                 const int32_t e = s.active_springs[q], a = sp.i[e], b = sp.j[e];
                 const double dx = x.x[b] - x.x[a], dy = x.y[b] - x.y[a], dz = x.z[b] - x.z[a];
                 const double l = std::max(std::sqrt(dx * dx + dy * dy + dz * dz), 1e-12);
                 const double rest = sp.rest_length_mm[e];
                 const double tension = t.stiffness_n_per_m[e] * (l - rest) / l;
                 f.x[e] = tension * dx, f.y[e] = tension * dy, f.z[e] = tension * dz;
                 float* d = dir + 4 * static_cast<int64_t>(e);
                 d[0] = static_cast<float>(dx / l), d[1] = static_cast<float>(dy / l);
                 d[2] = static_cast<float>(dz / l);
                 d[3] = static_cast<float>(std::max(0.0, 1.0 - rest / l));
               }
             });
}

// Per spring k [u u^T + alpha (I - u u^T)] (p_i - p_j), with the direction and alpha =
// max(0, 1 - L/l) of the last linearisation: the geometric term is clamped at zero so the
// matrix stays positive definite under compression.
void spring_product(const Solver& s, int32_t i, const ConstCols& p, double& kx, double& ky,
                    double& kz) {
  const SpringTerm& t = s.springs;
  const float* dir = t.dir.data();
  const double pix = p.x[i], piy = p.y[i], piz = p.z[i];
  for (int32_t a = t.adj_offsets[i]; a < t.adj_offsets[i + 1]; ++a) {
    const int32_t e = t.adj_spring[a], j = t.adj_other[a];
    const double dx = pix - p.x[j], dy = piy - p.y[j], dz = piz - p.z[j];
    const float* u = dir + 4 * static_cast<int64_t>(e);
    const double cx = u[0], cy = u[1], cz = u[2];
    const double along = cx * dx + cy * dy + cz * dz;
    const double k = t.stiffness_n_per_m[e], ka = k * u[3];
    // k (along u + alpha (d - along u)) = k alpha d + k (1 - alpha) along u
    const double ku = (k - ka) * along;
    kx += ka * dx + ku * cx, ky += ka * dy + ku * cy, kz += ka * dz + ku * cz;
  }
}

void spring_diagonal(const Solver& s, int32_t i, double& d0, double& d1, double& d2) {
  const SpringTerm& t = s.springs;
  const float* dir = t.dir.data();
  for (int32_t a = t.adj_offsets[i]; a < t.adj_offsets[i + 1]; ++a) {
    const int32_t e = t.adj_spring[a];
    const float* u = dir + 4 * static_cast<int64_t>(e);
    const double k = t.stiffness_n_per_m[e], ka = k * u[3], kb = k - ka;
    d0 += ka + kb * u[0] * u[0], d1 += ka + kb * u[1] * u[1], d2 += ka + kb * u[2] * u[2];
  }
}

double EdgeSprings::energy_mj(const Solver& s, const Eigen::MatrixX3d& x) {
  const Springs& sp = s.model->springs;
  double e = 0.0;
  for (size_t k = 0; k < sp.size(); ++k) {
    const double l = (x.row(sp.i[k]) - x.row(sp.j[k])).norm() - sp.rest_length_mm[k];
    e += 0.5 * s.springs.stiffness_n_per_m[k] * l * l;  // N/m * mm^2 = 1e-3 N mm = 1e-6 J
  }
  return e;
}

double EdgeSprings::part_energy_mj(const Solver& s, const Eigen::MatrixX3d& x, bool active) {
  const Springs& sp = s.model->springs;
  const auto spring = [&](size_t k) {
    const double l = (x.row(sp.i[k]) - x.row(sp.j[k])).norm() - sp.rest_length_mm[k];
    return 0.5 * s.springs.stiffness_n_per_m[k] * l * l;
  };
  double e = 0.0;
  if (active) {
    for (int32_t k : s.active_springs) e += spring(static_cast<size_t>(k));
  } else {
    for (size_t k = 0; k < sp.size(); ++k)
      if (!s.movable[sp.i[k]] && !s.movable[sp.j[k]]) e += spring(k);
  }
  return e;
}

void EdgeSprings::forces(Solver& s, const Eigen::MatrixX3d& x, Eigen::MatrixX3d& f) {
  // Every spring, not only the active ones: this is the whole model's force at any x.
  const Springs& sp = s.model->springs;
  const auto springs = static_cast<int64_t>(sp.size());
  const int T = threads_for_springs(springs);
  const ConstCols p(x);
  Cols fs(s.springs.force);
  for_slices(springs, T, [&](int64_t begin, int64_t end, int) {
    spring_kernel<double>(begin, end, nullptr, sp.i.data(), sp.j.data(), sp.rest_length_mm.data(),
                          s.springs.stiffness_n_per_m.data(), p.x, p.y, p.z, fs.x, fs.y, fs.z);
  });
  for_slices(x.rows(), T, [&](int64_t begin, int64_t end, int) {
    for (int64_t i = begin; i < end; ++i) {
      double fx = 0.0, fy = 0.0, fz = 0.0;
      gather_springs(s, static_cast<int32_t>(i), fx, fy, fz);
      f(i, 0) += fx, f(i, 1) += fy, f(i, 2) += fz;
    }
  });
}

void EdgeSprings::add_stiffness_rows(const Solver& s, std::vector<double>& row) {
  // 2 k at each end: k u u^T in its own block and minus that in the other end's, each counted
  // as k (its largest entry; the explicit limit's estimate since the paper model, which the
  // stability watch backs).
  const Springs& sp = s.model->springs;
  for (size_t e = 0; e < sp.size(); ++e) {
    row[sp.i[e]] += 2.0 * s.springs.stiffness_n_per_m[e];
    row[sp.j[e]] += 2.0 * s.springs.stiffness_n_per_m[e];
  }
}

void EdgeSprings::add_rest_stiffness(const Solver& s, const std::vector<int32_t>& row,
                                     BlockRows& K) {
  // k u u^T per spring, at its rest length (no geometric term).
  const Model& m = *s.model;
  const Springs& sp = m.springs;
  for (size_t e = 0; e < sp.size(); ++e) {
    const int32_t a = row[sp.i[e]], b = row[sp.j[e]];
    if (a < 0 && b < 0) continue;
    const Eigen::Vector3d u = (m.X.row(sp.j[e]) - m.X.row(sp.i[e])).normalized();
    const Eigen::Matrix3d k = s.springs.stiffness_n_per_m[e] * u * u.transpose();
    const auto add = [&](int32_t r, int32_t c, double sign) {
      double* block = K.at(r, c);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) block[3 * i + j] += sign * k(i, j);
    };
    if (a >= 0) add(a, a, 1.0);
    if (b >= 0) add(b, b, 1.0);
    if (a >= 0 && b >= 0) add(a, b, -1.0), add(b, a, -1.0);
  }
}

}  // namespace lamina::sim::detail
