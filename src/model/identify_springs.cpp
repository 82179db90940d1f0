#include "lamina/model/identify_springs.h"

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <numbers>

#include "lamina/core/error.h"
#include "lamina/model/layer_normals.h"
#include "mandel.h"

namespace lamina::model {
namespace {

// Projecting onto the isotropic tensors (in Mandel form, mandel.h) is the same as averaging
// over all orientations (what a curved organ does to its layers' frames).
using detail::Mandel;
inline Mandel isotropic(double lambda, double mu) {
  return detail::isotropic_tensor(lambda, mu);
}

// A spring along d contributes k l^2 D D^T to the network's tensor (times 1 / V), D = (d1^2,
// d2^2, d3^2, sqrt2 d2 d3, sqrt2 d1 d3, sqrt2 d1 d2): its energy is 1/2 k (l d.eps.d)^2. In the
// node's frame (normal = axis 3) the spring makes angle theta with the normal; around the normal
// the layer has no preferred direction, so the contribution is averaged over the azimuth (eight
// equally spaced azimuths average the quartic terms exactly).
Mandel transverse_average(double cos_theta) {
  const double c = std::clamp(cos_theta, -1.0, 1.0), s = std::sqrt(1.0 - c * c);
  Mandel sum = Mandel::Zero();
  constexpr int kAzimuths = 8;
  for (int k = 0; k < kAzimuths; ++k) {
    const double phi = 2.0 * std::numbers::pi * (k + 0.5) / kAzimuths;
    const double d1 = s * std::cos(phi), d2 = s * std::sin(phi), d3 = c;
    Eigen::Matrix<double, 6, 1> D;
    D << d1 * d1, d2 * d2, d3 * d3, std::numbers::sqrt2 * d2 * d3, std::numbers::sqrt2 * d1 * d3,
        std::numbers::sqrt2 * d1 * d2;
    sum += D * D.transpose();
  }
  return sum / kAzimuths;
}

double dot(const Mandel& a, const Mandel& b) {
  return (a.array() * b.array()).sum();
}

// (lambda, mu) of the isotropic tensor closest to c: its average over all orientations.
Eigen::Vector2d isotropic_part(const Mandel& c) {
  const Mandel L = isotropic(1.0, 0.0), M = isotropic(0.0, 1.0);
  const Eigen::Matrix2d g{{dot(L, L), dot(L, M)}, {dot(M, L), dot(M, M)}};
  return g.ldlt().solve(Eigen::Vector2d(dot(L, c), dot(M, c)));
}

}  // namespace

void check_elastic_material(const ElasticMaterial& m) {
  if (!(m.young_modulus_kpa > 0.0 && std::isfinite(m.young_modulus_kpa)))
    throw invalid_input("material.young_modulus_kpa", "must be > 0 kPa");
  if (!(m.poisson_ratio >= 0.0 && m.poisson_ratio < 0.5))
    throw invalid_input("material.poisson_ratio",
                        "must be in [0, 0.5) (0.5 is incompressible: use 0.45-0.49)");
}

SpringIdentification identify_springs(const Model& m, const ElasticMaterial& material,
                                      std::vector<double>& stiffness) {
  check_elastic_material(material);
  const double E = material.young_modulus_kpa, nu = material.poisson_ratio;
  SpringIdentification out;
  out.shear_modulus_kpa = E / (2.0 * (1.0 + nu));
  out.lame_lambda_kpa = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
  const double mu = out.shear_modulus_kpa, lambda = out.lame_lambda_kpa;
  // Springs alone have lambda = mu: they take mu, the volume term the rest of lambda. Below
  // nu = 1/4 (lambda < mu) nothing can lower lambda: the springs get the best compromise.
  out.volume_stiffness_kpa = std::max(0.0, lambda - mu);
  const Mandel target = isotropic(std::min(lambda, mu), mu);

  // Each node's volume (its lumped mass over the density) is shared out among its springs.
  const Springs& sp = m.springs;
  const int32_t n = m.node_count();
  std::vector<int32_t> degree(static_cast<size_t>(n), 0);
  for (size_t e = 0; e < sp.size(); ++e) ++degree[sp.i[e]], ++degree[sp.j[e]];
  std::vector<double> share(sp.size());
  double volume = 0.0;
  for (int32_t i = 0; i < n; ++i) volume += m.mass_kg[i] / m.density_kg_per_mm3;
  auto node_share = [&](int32_t i) {
    return degree[i] > 0 ? m.mass_kg[i] / m.density_kg_per_mm3 / degree[i] : 0.0;
  };
  for (size_t e = 0; e < sp.size(); ++e) share[e] = node_share(sp.i[e]) + node_share(sp.j[e]);

  // Each kind's tensor per unit c E, summed over the organ in the springs' local frames.
  const Eigen::MatrixX3d normal = layer_normals(m);
  Mandel B[2] = {Mandel::Zero(), Mandel::Zero()};
  for (size_t e = 0; e < sp.size(); ++e) {
    const int32_t a = sp.i[e], b = sp.j[e];
    const Eigen::RowVector3d d = (m.X.row(b) - m.X.row(a)).normalized();
    const Eigen::RowVector3d nn = normal.row(a) + normal.row(b);
    const double len = nn.norm();
    const double c = len > 1e-12 ? d.dot(nn) / len : 0.0;
    B[sp.kind[e] == SpringKind::kInterLayer ? 1 : 0] += share[e] * transverse_average(c);
  }
  for (Mandel& b : B) b /= volume;

  // The two constants: the springs' tensor averaged over all orientations (what the organ's
  // curved layers see as a whole) must have the target's shear modulus exactly, and within that
  // the local tensor must be as close to isotropic as least squares can make it:
  //   min || c0 B0 + c1 B1 - T ||  subject to  c0 mu(B0) + c1 mu(B1) = mu / E,  c >= 0.
  const Mandel T = target / E;
  const Eigen::Vector2d beta(isotropic_part(B[0])[1], isotropic_part(B[1])[1]);
  const double want = mu / E;
  Eigen::Matrix3d kkt;
  kkt << dot(B[0], B[0]), dot(B[0], B[1]), beta[0], dot(B[1], B[0]), dot(B[1], B[1]), beta[1],
      beta[0], beta[1], 0.0;
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  if (beta[0] > 0.0 && beta[1] > 0.0) {
    const Eigen::Vector3d sol =
        kkt.fullPivLu().solve(Eigen::Vector3d(dot(B[0], T), dot(B[1], T), want));
    c = sol.head<2>();
  }
  if (!(c[0] > 0.0 && c[1] > 0.0)) {
    // One kind alone (a skin-only model has no links): the better of the two.
    double best_misfit = std::numeric_limits<double>::infinity();
    c.setZero();
    for (int k = 0; k < 2; ++k) {
      if (!(beta[k] > 0.0)) continue;
      Eigen::Vector2d one = Eigen::Vector2d::Zero();
      one[k] = want / beta[k];
      const double misfit = (one[0] * B[0] + one[1] * B[1] - T).norm();
      if (misfit < best_misfit) c = one, best_misfit = misfit;
    }
  }
  if (!(c[0] > 0.0 || c[1] > 0.0))
    throw invalid_input(m.source, "the spring network has no springs to identify");
  // A kind the fit leaves at zero would leave its springs slack; give them the other's scale
  // instead (it only happens for networks the fit cannot make isotropic anyway).
  out.c_intra = c[0] > 0.0 ? c[0] : c[1];
  out.c_inter = c[1] > 0.0 ? c[1] : c[0];

  stiffness.resize(sp.size());
  for (size_t e = 0; e < sp.size(); ++e) {
    const double l = sp.rest_length_mm[e];
    const double ck = sp.kind[e] == SpringKind::kInterLayer ? out.c_inter : out.c_intra;
    stiffness[e] = ck * E * share[e] / (l * l);  // kPa mm^3 / mm^2 = mN/mm = N/m
  }

  // How well it holds: the network's tensor against the target, and the isotropic tensor
  // closest to springs plus volume term.
  const Mandel net = E * (out.c_intra * B[0] + out.c_inter * B[1]);
  out.fit_residual = (net - target).norm() / target.norm();
  Mandel with_volume = net;
  with_volume.topLeftCorner<3, 3>().array() += out.volume_stiffness_kpa;
  const Eigen::Vector2d lm = isotropic_part(with_volume);
  out.effective_young_kpa = lm[1] * (3.0 * lm[0] + 2.0 * lm[1]) / (lm[0] + lm[1]);
  out.effective_poisson = lm[0] / (2.0 * (lm[0] + lm[1]));
  return out;
}

}  // namespace lamina::model
