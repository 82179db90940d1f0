#include "lamina/model/identify_tets.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "find_spring.h"
#include "lamina/core/error.h"
#include "mandel.h"

namespace lamina::model {
namespace {

using Mat6 = detail::Mandel;
using Vec6 = Eigen::Matrix<double, 6, 1>;

using detail::find_spring;

// Each node's first spring in springs sorted by (i, j) (#nodes + 1): the spring between a and b
// is then found in min(a, b)'s few entries, not by two binary searches over all of them (a
// cut's identification looks up six per tetrahedron).
std::vector<int32_t> spring_rows(const Springs& sp, int32_t nodes) {
  std::vector<int32_t> first(static_cast<size_t>(nodes) + 1, 0);
  for (const int32_t i : sp.i) ++first[static_cast<size_t>(i) + 1];
  for (int32_t i = 0; i < nodes; ++i) first[i + 1] += first[i];
  return first;
}

int32_t spring_in_rows(const Springs& sp, const std::vector<int32_t>& first, int32_t a, int32_t b) {
  const int32_t i = std::min(a, b), j = std::max(a, b);
  for (int32_t e = first[i]; e < first[i + 1]; ++e)
    if (sp.j[e] == j) return e;
  return -1;
}

// Whether `before` was identified with the constants `out` is being identified with.
bool same_constants(const TetIdentification& before, const TetIdentification& out) {
  return before.elasticity == out.elasticity && before.shear_modulus_kpa == out.shear_modulus_kpa &&
         before.lame_lambda_kpa == out.lame_lambda_kpa;
}

// `known` fits the model and the identification it names.
void check_known(const Model& m, const KnownTets& known) {
  const auto problem = [&](const std::string& what) {
    throw invalid_input(m.source.empty() ? std::string("model") : m.source,
                        "known tetrahedra: " + what);
  };
  if (known.tets.size() != static_cast<size_t>(m.tets.size()))
    problem(std::to_string(known.tets.size()) + " entries for " + std::to_string(m.tets.size()) +
            " tetrahedra");
  for (const int32_t k : known.tets)
    if (k >= known.before->q_n_per_m.rows())
      problem("tetrahedron " + std::to_string(k) + " is not one of the identified model's");
  if (!known.springs.empty() && known.springs.size() != known.before->spring_n_per_m.size())
    problem(std::to_string(known.springs.size()) + " springs for the identified model's " +
            std::to_string(known.before->spring_n_per_m.size()));
  for (const int32_t e : known.springs)
    if (e >= static_cast<int64_t>(m.springs.size()))
      problem("spring " + std::to_string(e) + " is not one of the model's");
}

TetIdentification identify(const Model& m, const ElasticMaterial& material,
                           TetElasticity elasticity, const KnownTets* known) {
  check_elastic_material(material);
  if (!m.has_tets())
    throw invalid_input(m.source.empty() ? std::string("model") : m.source,
                        "has no tetrahedra (built with --structure links): its springs are "
                        "identified per spring kind instead");
  const double E = material.young_modulus_kpa, nu = material.poisson_ratio;
  TetIdentification out;
  out.elasticity = elasticity;
  out.shear_modulus_kpa = E / (2.0 * (1.0 + nu));
  out.lame_lambda_kpa = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
  const double mu = out.shear_modulus_kpa, lambda = out.lame_lambda_kpa;
  // Coupled: the springs carry mu and 90% of lambda, the signed-volume term the rest (measured:
  // all of lambda in it made the model 33-70% stiffer than corotational FEM at 10-20%
  // indentation, because det F - 1 penalises the second-order volume change of a large shear
  // that tr(strain) does not; docs/physics.md). Independent springs obey the Cauchy relation
  // lambda = mu: they take mu, the volume term the rest.
  const bool coupled = elasticity == TetElasticity::kCoupled;
  out.volume_modulus_kpa = coupled ? kVolumeShare * lambda : std::max(0.0, lambda - mu);
  out.guard_modulus_kpa = kGuardModulus * (lambda + 2.0 * mu);
  const Mat6 C =
      detail::isotropic_tensor(coupled ? (1.0 - kVolumeShare) * lambda : std::min(lambda, mu), mu);

  const Springs& sp = m.springs;
  const Eigen::Index nt = m.tets.size();
  if (known && !(known->before && same_constants(*known->before, out))) known = nullptr;
  if (known) check_known(m, *known);
  const std::vector<int32_t> rows = spring_rows(sp, m.node_count());
  out.spring_n_per_m.assign(sp.size(), 0.0);
  out.tet_springs.resize(nt, 6);
  out.q_n_per_m = Eigen::Matrix<double, Eigen::Dynamic, 21, Eigen::RowMajor>::Zero(nt, 21);
  out.rest_volume_mm3.resize(static_cast<size_t>(nt));
  // Each tetrahedron on its own, in parallel (a cut identifies every tetrahedron again: most of
  // its update at paper size); the springs' sums below, in tetrahedron order as ever.
  Eigen::Index bad = nt;  // the first tetrahedron whose edge is no spring
#pragma omp parallel for schedule(static) reduction(min : bad)
  for (Eigen::Index t = 0; t < nt; ++t) {
    if (known && known->tets[static_cast<size_t>(t)] >= 0) {
      const int32_t from = known->tets[static_cast<size_t>(t)];
      const TetIdentification& before = *known->before;
      for (int k = 0; k < 6; ++k) {
        const int32_t a = m.tets.T(t, kTetEdge[k][0]), b = m.tets.T(t, kTetEdge[k][1]);
        // The earlier spring's one successor, if it joins these corners; else searched.
        int32_t e = known->springs.empty() ? -1 : known->springs[before.tet_springs(from, k)];
        if (e < 0 || sp.i[e] != std::min(a, b) || sp.j[e] != std::max(a, b))
          e = spring_in_rows(sp, rows, a, b);
        if (e < 0) bad = std::min(bad, t);
        out.tet_springs(t, k) = std::max(e, 0);
      }
      out.q_n_per_m.row(t) = before.q_n_per_m.row(from);
      out.rest_volume_mm3[static_cast<size_t>(t)] =
          before.rest_volume_mm3[static_cast<size_t>(from)];
      continue;
    }
    Eigen::Vector3d p[4];
    for (int c = 0; c < 4; ++c) p[c] = m.X.row(m.tets.T(t, c)).transpose();
    const double volume = (p[1] - p[0]).cross(p[2] - p[0]).dot(p[3] - p[0]) / 6.0;
    out.rest_volume_mm3[static_cast<size_t>(t)] = volume;
    // A: dl_k = L_k d_k.eps.d_k = A_k . eps (Mandel).
    Mat6 A;
    Eigen::Vector3d w[6];
    for (int k = 0; k < 6; ++k) {
      const int a = m.tets.T(t, kTetEdge[k][0]), b = m.tets.T(t, kTetEdge[k][1]);
      const int32_t e = spring_in_rows(sp, rows, a, b);
      if (e < 0) bad = std::min(bad, t);
      out.tet_springs(t, k) = std::max(e, 0);
      const Eigen::Vector3d edge = p[kTetEdge[k][1]] - p[kTetEdge[k][0]];
      const double L = edge.norm();
      const Eigen::Vector3d d = edge / L;
      w[k] = d;
      A.row(k) << L * d.x() * d.x(), L * d.y() * d.y(), L * d.z() * d.z(),
          L * std::sqrt(2.0) * d.y() * d.z(), L * std::sqrt(2.0) * d.x() * d.z(),
          L * std::sqrt(2.0) * d.x() * d.y();
    }
    // Q = V A^-T C A^-1: the tetrahedron's energy 1/2 dl^T Q dl. A positive tetrahedron has
    // independent edge directions in this sense, so A is invertible.
    const Mat6 Ainv = A.partialPivLu().inverse();
    // A copy a cut made carries its share of the tetrahedron's material (model::cut_tetrahedra).
    const double share = m.tets.share_of(t);
    const Mat6 Q = share * volume * Ainv.transpose() * C * Ainv;
    if (coupled) {
      for (int k = 0, at = 0; k < 6; ++k)
        for (int j = k; j < 6; ++j) out.q_n_per_m(t, at++) = Q(k, j);
      continue;
    }
    // Independent springs (Lloyd et al. 2007): the six constants whose stiffness matrix
    // sum_k s_k J_k^T J_k is closest, in the Frobenius norm, to the element's J^T Q J (J the
    // 6 x 12 Jacobian of the stretches). In edge space: G s = diag(P Q P) with P = J J^T (P_km
    // = J_k . J_m, the overlap of two edges' 12-vectors) and G = P .* P.
    Mat6 P = Mat6::Zero();
    for (int k = 0; k < 6; ++k)
      for (int j = 0; j < 6; ++j) {
        double overlap = 0.0;
        for (int ck = 0; ck < 2; ++ck)
          for (int cj = 0; cj < 2; ++cj)
            if (kTetEdge[k][ck] == kTetEdge[j][cj])
              overlap += (ck == 0 ? -1.0 : 1.0) * (cj == 0 ? -1.0 : 1.0) * w[k].dot(w[j]);
        P(k, j) = overlap;
      }
    const Mat6 G = P.cwiseProduct(P);
    const Vec6 rhs = (P * Q * P).diagonal();
    const Vec6 s = G.ldlt().solve(rhs);
    // A constant the fit drives negative (a flat-ish element) is left at zero: the edge's other
    // tetrahedra still hold it.
    for (int k = 0, at = 0; k < 6; at += 6 - k, ++k) out.q_n_per_m(t, at) = std::max(s[k], 0.0);
  }
  if (bad < nt) {
    const Eigen::Index t = bad;
    int32_t a = -1, b = -1;
    for (int k = 0; k < 6 && a < 0; ++k)
      if (find_spring(sp, m.tets.T(t, kTetEdge[k][0]), m.tets.T(t, kTetEdge[k][1])) < 0)
        a = m.tets.T(t, kTetEdge[k][0]), b = m.tets.T(t, kTetEdge[k][1]);
    throw invalid_input(m.source, "tetrahedron " + std::to_string(t) + ": edge " +
                                      std::to_string(a) + "-" + std::to_string(b) +
                                      " is not a spring of the model");
  }
  // Each spring's constant: its tetrahedra's diagonal terms (Q's (k, k) at 0, 6, 11, 15, 18, 20).
  for (Eigen::Index t = 0; t < nt; ++t)
    for (int k = 0, at = 0; k < 6; at += 6 - k, ++k)
      out.spring_n_per_m[static_cast<size_t>(out.tet_springs(t, k))] += out.q_n_per_m(t, at);
  return out;
}

}  // namespace

TetIdentification identify_tets(const Model& m, const ElasticMaterial& material,
                                TetElasticity elasticity) {
  return identify(m, material, elasticity, nullptr);
}

TetIdentification identify_tets(const Model& m, const ElasticMaterial& material,
                                TetElasticity elasticity, const KnownTets& known) {
  return identify(m, material, elasticity, &known);
}

}  // namespace lamina::model
