#pragma once
/// \file
/// Elastic constants of a model's tetrahedra from a tissue's Young's modulus and Poisson's ratio
/// (docs/physics.md, "The tetrahedral network").
///
/// For one tetrahedron the six edge stretches dl fix its linear strain, and its linear-elastic
/// energy V/2 eps:C:eps is a quadratic form in them: 1/2 dl^T Q dl with Q = V A^-T C A^-1 (A maps
/// the strain to the stretches, dl_k = L_k d_k.eps.d_k). Q's diagonal are the edge springs'
/// constants; its off-diagonal couples the six springs of a tetrahedron. With the coupling,
/// springs plus the per-tetrahedron volume term reproduce linear elasticity exactly at small
/// strain, in any rotation (edge lengths do not see rotations); without it (TetElasticity::
/// kSprings) each tetrahedron's springs are the least-squares fit of Lloyd et al. 2007 to its
/// stiffness matrix, which central springs can only match for nu = 1/4.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "lamina/model/identify_springs.h"
#include "lamina/model/model.h"

namespace lamina::model {

/// How a model's tetrahedra carry the tissue's elasticity.
enum class TetElasticity : uint8_t {
  /// Edge springs (Q's diagonal) coupled within each tetrahedron (Q's off-diagonal) carry mu and
  /// most of lambda; the per-tetrahedron signed-volume term carries kVolumeShare of lambda.
  /// Exact linear elasticity at small strain.
  kCoupled,
  /// Independent edge springs fitted per tetrahedron to its stiffness with lambda = mu (what
  /// central springs can represent; Lloyd et al. 2007); the volume term carries lambda - mu.
  kSprings,
};

/// The share of lambda the coupled form's signed-volume term carries (the springs carry the rest).
inline constexpr double kVolumeShare = 0.1;
/// The inversion guard's modulus over the P-wave modulus lambda + 2 mu.
inline constexpr double kGuardModulus = 100.0;

/// Edge k of a tetrahedron runs from corner kTetEdge[k][0] to corner kTetEdge[k][1].
inline constexpr int kTetEdge[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

/// The identified constants.
struct TetIdentification {
  TetElasticity elasticity = TetElasticity::kCoupled;
  double shear_modulus_kpa = 0.0;  ///< mu = E / (2 (1 + nu))
  double lame_lambda_kpa = 0.0;    ///< lambda = E nu / ((1 + nu) (1 - 2 nu))
  /// k_v, kPa: each tetrahedron stores k_v (V - V0)^2 / (2 V0), which at small strain is
  /// k_v / 2 tr(eps)^2 V0: a share k_v of lambda. Signed V: an inverted tetrahedron is pushed
  /// back towards positive volume.
  double volume_modulus_kpa = 0.0;
  /// k_g, kPa: below a tenth of its rest volume a tetrahedron also stores
  /// k_g (V0/10 - V)^2 / (2 V0), kGuardModulus x (lambda + 2 mu).
  double guard_modulus_kpa = 0.0;
  /// #springs: each spring's constant, N/m (= mN/mm): its tetrahedra's shares (Q's diagonal)
  /// summed over the tetrahedra that share the edge.
  std::vector<double> spring_n_per_m;
  /// #T by 6: the spring along each edge of each tetrahedron (edge order kTetEdge).
  Eigen::Matrix<int32_t, Eigen::Dynamic, 6, Eigen::RowMajor> tet_springs;
  /// #T by 21: each tetrahedron's Q, N/m, its upper triangle row by row ((0,0), (0,1), ...,
  /// (0,5), (1,1), ..., (5,5)): the diagonal is the tetrahedron's share of its six springs, the
  /// rest their coupling (zero for kSprings).
  Eigen::Matrix<double, Eigen::Dynamic, 21, Eigen::RowMajor> q_n_per_m;
  /// #T: rest volumes, mm^3
  std::vector<double> rest_volume_mm3;
};

/// Identifies every tetrahedron's constants.
/// @param[in] model       rest positions, springs (sorted by (i, j): the tetrahedra's edges)
///                        and tetrahedra
/// @param[in] material    E and nu (check_elastic_material())
/// @param[in] elasticity  coupled (default) or independent springs
/// \note Throws lamina::Error (kInvalidInput) if the model has no tetrahedra or a tetrahedron's
///   edge is not one of its springs.
TetIdentification identify_tets(const Model& model, const ElasticMaterial& material,
                                TetElasticity elasticity = TetElasticity::kCoupled);

/// What an earlier identification knows of a model (a cut's: the model it was cut from).
struct KnownTets {
  const TetIdentification* before = nullptr;  ///< of the earlier model, same material
  /// Per tetrahedron: the same element (the same rest corners, share and material) in the
  /// earlier model, whose constants it takes, or -1 (model::same_tets())
  std::vector<int32_t> tets;
  /// Per spring of the earlier model: the one spring of this model between its ends' nodes, or
  /// -1 (none, or several: a node the cut copied) (model::same_springs()); may be empty. A
  /// known tetrahedron's springs are found through it instead of searched.
  std::vector<int32_t> springs;
};

/// identify_tets() for a model some of whose tetrahedra were identified before: each one
/// `known.tets` names takes its constants from `known.before` instead of inverting its 6x6
/// again (a cut keeps all but a few). `known.before` must be of the same material and
/// elasticity (else every tetrahedron is identified afresh).
/// \note Throws as identify_tets(), and lamina::Error (kInvalidInput) if `known.tets` is not one
///   entry per tetrahedron naming tetrahedra of `known.before`, or `known.springs` names springs
///   that are not this model's.
TetIdentification identify_tets(const Model& model, const ElasticMaterial& material,
                                TetElasticity elasticity, const KnownTets& known);

}  // namespace lamina::model
