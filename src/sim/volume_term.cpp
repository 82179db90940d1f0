// The volume term (Material::volume_stiffness_kpa): each region between neighbouring layers, and
// the core inside the deepest, stores K_v (V - V0)^2 / (2 V0) like a fluid of bulk modulus K_v.
// Its pressure p = K_v (V - V0) / V0 pushes on the two layers that bound it, so a node of layer
// k feels -(p_k - p_{k-1}) dV_k/dx, p_k the pressure of the region just inside layer k (p_{-1}
// = 0 outside the organ). dV_k/dx_i = 1/6 sum over i's triangles (i, b, c) of x_b x x_c.
#include <algorithm>
#include <array>

#include "force_terms.h"
#include "solver.h"

namespace lamina::sim::detail {
namespace {

// Volume of region r at rest and now, from the enclosed volumes of its bounding layers.
double region_volume(const double* layer_volume, size_t layers, size_t r) {
  return r + 1 < layers ? layer_volume[r] - layer_volume[r + 1] : layer_volume[r];
}
double rest_region_volume(const Solver& s, size_t r) {
  return region_volume(s.rest_layer_volume_mm3.data(), s.rest_layer_volume_mm3.size(), r);
}

}  // namespace

double volume6_slice(const Eigen::MatrixX3i& F, const Eigen::MatrixX3d& xm, const int32_t* list,
                     int64_t begin, int64_t end) {
  const ConstCols x(xm);
  double v6 = 0.0;
  for (int64_t q = begin; q < end; ++q) {
    const Eigen::Index f = list ? list[q] : q;
    const int32_t a = F(f, 0), b = F(f, 1), c = F(f, 2);
    v6 += x.x[a] * (x.y[b] * x.z[c] - x.z[b] * x.y[c]) +
          x.y[a] * (x.z[b] * x.x[c] - x.x[b] * x.z[c]) +
          x.z[a] * (x.x[b] * x.y[c] - x.y[b] * x.x[c]);
  }
  return v6;
}

double volume6(const Eigen::MatrixX3i& F, const Eigen::MatrixX3d& xm, const int32_t* list,
               int64_t count, int threads) {
  Partials part;
  for_slices(count, threads, [&](int64_t begin, int64_t end, int t) {
    part[t].a = volume6_slice(F, xm, list, begin, end);
  });
  double sum = 0.0;
  for (int t = 0; t < std::max(threads, 1); ++t) sum += part[t].a;
  return sum;
}

double layer_volume_now(const Solver& s, const Eigen::MatrixX3d& x, size_t k, int threads) {
  const Eigen::MatrixX3i& F = s.model->layers[k].F;
  const std::vector<int32_t>& tris = s.layer_triangles[k];
  const auto n = static_cast<int64_t>(tris.size());
  return (s.frozen_layer_volume6_mm3[k] + (n == F.rows()
                                               ? volume6(F, x, nullptr, n, threads)
                                               : volume6(F, x, tris.data(), n, threads))) /
         6.0;
}

double region_stiffness(const Solver& s, size_t r) {
  return s.material.volume_stiffness_kpa / rest_region_volume(s, r);
}

void setup_volume_term(Solver& s) {
  const Model& m = *s.model;
  const int32_t n = m.node_count();
  s.volume.corner_offsets.assign(static_cast<size_t>(n) + 1, 0);
  for (const ModelLayer& l : m.layers)
    for (Eigen::Index t = 0; t < l.F.rows(); ++t)
      for (int c = 0; c < 3; ++c) ++s.volume.corner_offsets[l.F(t, c) + 1];
  for (int32_t i = 0; i < n; ++i) s.volume.corner_offsets[i + 1] += s.volume.corner_offsets[i];
  s.volume.corner_pairs.resize(2 * static_cast<size_t>(s.volume.corner_offsets[n]));
  std::vector<int32_t> fill(s.volume.corner_offsets.begin(), s.volume.corner_offsets.end() - 1);
  for (const ModelLayer& l : m.layers)
    for (Eigen::Index t = 0; t < l.F.rows(); ++t)
      for (int c = 0; c < 3; ++c) {
        const int32_t i = l.F(t, c), at = 2 * fill[i]++;
        s.volume.corner_pairs[at] = l.F(t, (c + 1) % 3);
        s.volume.corner_pairs[at + 1] = l.F(t, (c + 2) % 3);
      }
  s.volume.pressure_jump_kpa.assign(m.layers.size(), 0.0);
  s.volume.gradient = Eigen::MatrixX3d::Zero(n, 3);
}

void layer_volume_gradient(const Solver& s, const ConstCols& x, int32_t i, double& gx, double& gy,
                           double& gz) {
  double ax = 0.0, ay = 0.0, az = 0.0;
  for (int32_t a = s.volume.corner_offsets[i]; a < s.volume.corner_offsets[i + 1]; ++a) {
    const int32_t b = s.volume.corner_pairs[2 * a], c = s.volume.corner_pairs[2 * a + 1];
    ax += x.y[b] * x.z[c] - x.z[b] * x.y[c];
    ay += x.z[b] * x.x[c] - x.x[b] * x.z[c];
    az += x.x[b] * x.y[c] - x.y[b] * x.x[c];
  }
  gx = ax / 6.0, gy = ay / 6.0, gz = az / 6.0;
}

// Each layer's pressure jump from the layers' enclosed volumes now.
void set_pressures(Solver& s, const double* now) {
  const size_t layers = s.model->layers.size();
  double outside = 0.0;  // pressure of the region outside the layer: none outside the organ
  for (size_t k = 0; k < layers; ++k) {
    const double rest = rest_region_volume(s, k);
    const double p =
        s.material.volume_stiffness_kpa * (region_volume(now, layers, k) - rest) / rest;
    s.volume.pressure_jump_kpa[k] = p - outside;
    outside = p;
  }
}

void update_volume_term(Solver& s, const Eigen::MatrixX3d& xm, int threads) {
  std::array<double, kMaxLayers> now{};
  for (size_t k = 0; k < s.model->layers.size(); ++k) now[k] = layer_volume_now(s, xm, k, threads);
  set_pressures(s, now.data());
  const ConstCols x(xm);
  Cols g(s.volume.gradient);
  for_slices(static_cast<int64_t>(s.active_nodes.size()), threads,
             [&](int64_t begin, int64_t end, int) {
               for (int64_t q = begin; q < end; ++q) {
                 const int32_t i = s.active_nodes[q];
                 layer_volume_gradient(s, x, i, g.x[i], g.y[i], g.z[i]);
               }
             });
}

void volume_multipliers(const Solver& s, const Eigen::MatrixX3d& pm, int threads,
                        double* multiplier) {
  const size_t layers = s.model->layers.size();
  const ConstCols p(pm), g(s.volume.gradient);
  const int32_t* layer_of = s.model->layer_of.data();
  struct alignas(64) Dots {
    std::array<double, kMaxLayers> d{};
  };
  std::array<Dots, kMaxThreads> part;
  for_slices(static_cast<int64_t>(s.active_nodes.size()), threads,
             [&](int64_t begin, int64_t end, int t) {
               Dots acc;
               for (int64_t q = begin; q < end; ++q) {
                 const int32_t i = s.active_nodes[q];
                 if (layer_of[i] < 0) continue;  // interior nodes bound no region
                 acc.d[layer_of[i]] += g.x[i] * p.x[i] + g.y[i] * p.y[i] + g.z[i] * p.z[i];
               }
               part[t] = acc;
             });
  std::array<double, kMaxLayers> dot{};
  for (int t = 0; t < std::max(threads, 1); ++t)
    for (size_t k = 0; k < layers; ++k) dot[k] += part[t].d[k];
  // Region r's volume changes by dot[r] - dot[r + 1] along p; its stiffness c_r = K_v / V0_r.
  double outside = 0.0;
  for (size_t k = 0; k < layers; ++k) {
    const double region = (k + 1 < layers ? dot[k] - dot[k + 1] : dot[k]) * region_stiffness(s, k);
    multiplier[k] = region - outside;
    outside = region;
  }
}

void LayerVolume::add_stiffness_rows(const Solver& s, std::vector<double>& row) {
  const Model& m = *s.model;
  const size_t layers = m.layers.size();
  const ConstCols x(m.X);
  std::vector<double> g_max(static_cast<size_t>(m.node_count()));
  std::vector<double> layer_l1(layers, 0.0);  // ||g||_1 over each layer's nodes
  for (int32_t i = 0; i < m.surface_node_count(); ++i) {
    double gx, gy, gz;
    layer_volume_gradient(s, x, i, gx, gy, gz);
    g_max[i] = std::max({std::abs(gx), std::abs(gy), std::abs(gz)});
    layer_l1[m.layer_of[i]] += std::abs(gx) + std::abs(gy) + std::abs(gz);
  }
  // Region r is bounded by layers r and r + 1 (the core by the deepest alone).
  std::vector<double> region(layers);
  for (size_t r = 0; r < layers; ++r)
    region[r] = region_stiffness(s, r) * (layer_l1[r] + (r + 1 < layers ? layer_l1[r + 1] : 0.0));
  for (int32_t i = 0; i < m.surface_node_count(); ++i) {
    const auto k = static_cast<size_t>(m.layer_of[i]);
    row[i] += g_max[i] * (region[k] + (k > 0 ? region[k - 1] : 0.0));
  }
}

double LayerVolume::energy_mj(const Solver& s, const Eigen::MatrixX3d& x) {
  const Model& m = *s.model;
  std::vector<double> now(m.layers.size());
  for (size_t k = 0; k < m.layers.size(); ++k) now[k] = layer_volume(m, x, static_cast<int32_t>(k));
  double e = 0.0;
  for (size_t r = 0; r < now.size(); ++r) {
    const double rest = rest_region_volume(s, r);
    const double dv = region_volume(now.data(), now.size(), r) - rest;
    e += 0.5 * s.material.volume_stiffness_kpa * dv * dv / rest;  // kPa mm^3 = 1e-6 J
  }
  return e;
}

void LayerVolume::forces(Solver& s, const Eigen::MatrixX3d& xm, Eigen::MatrixX3d& f) {
  const Model& m = *s.model;
  const size_t layers = m.layers.size();
  std::array<double, kMaxLayers> now{}, jump{};
  for (size_t k = 0; k < layers; ++k) now[k] = layer_volume(m, xm, static_cast<int32_t>(k));
  double outside = 0.0;
  for (size_t k = 0; k < layers; ++k) {
    const double rest = rest_region_volume(s, k);
    const double p =
        s.material.volume_stiffness_kpa * (region_volume(now.data(), layers, k) - rest) / rest;
    jump[k] = p - outside;
    outside = p;
  }
  const ConstCols x(xm);
  for (int32_t i = 0; i < m.surface_node_count(); ++i) {
    double gx, gy, gz;
    layer_volume_gradient(s, x, i, gx, gy, gz);
    const double j = jump[static_cast<size_t>(m.layer_of[i])];
    f(i, 0) -= j * gx, f(i, 1) -= j * gy, f(i, 2) -= j * gz;
  }
}

}  // namespace lamina::sim::detail
