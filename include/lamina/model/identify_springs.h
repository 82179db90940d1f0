#pragma once
/// \file
/// Spring constants from a tissue's Young's modulus and Poisson's ratio (docs/physics.md).
///
/// Lloyd, Szekely and Harders (2007) identify spring constants by making a spring network's
/// stiffness match a linear-elastic finite element's in the least-squares sense. Lamina's network
/// is not a tetrahedral mesh (nested triangle layers joined by nearest-node links), so the same
/// least-squares match is made on the network's homogenised (Cauchy-Born) elasticity tensor:
/// each spring e gets k_e = c_kind E V_e / l_e^2, V_e its share of the organ's volume, and the
/// two constants c_intra, c_inter (layer edges, inter-layer links) are fitted so that, in every
/// node's frame (normal to its layer), the springs' tensor is closest to the isotropic one.
/// A network of central springs can only be isotropic with lambda = mu (Poisson's ratio 1/4):
/// for nu > 1/4 the springs carry the shear modulus mu and the volume term
/// (sim::Material::volume_stiffness_kpa) the remaining bulk stiffness lambda - mu.

#include <vector>

#include "lamina/model/model.h"

namespace lamina::model {

/// An isotropic linear-elastic tissue. Defaults: healthy human liver. Venkatesh et al. 2014
/// (J Magn Reson Imaging 39:1-8, MR elastography of 41 healthy livers) measured a shear
/// stiffness of 2.09 +- 0.22 kPa; with nu = 0.45 that is E = 2 (1 + nu) G = 6.06 kPa.
struct ElasticMaterial {
  double young_modulus_kpa = 6.0;  ///< E, kPa (= mN/mm^2), > 0
  double poisson_ratio = 0.45;     ///< nu, in [0, 0.5): soft tissue is nearly incompressible
};

/// What the identification found.
struct SpringIdentification {
  double shear_modulus_kpa = 0.0;       ///< mu = E / (2 (1 + nu))
  double lame_lambda_kpa = 0.0;         ///< lambda = E nu / ((1 + nu) (1 - 2 nu))
  double volume_stiffness_kpa = 0.0;    ///< K_v = max(0, lambda - mu): the volume term's share
  double c_intra = 0.0, c_inter = 0.0;  ///< k_e = c E V_e / l_e^2 for each kind of spring
  /// ||C_network - C_target|| / ||C_target|| (the tensor norm): 0 = the springs are exactly
  /// isotropic with the target's lambda and mu; a skin-only network, which cannot resist
  /// stretch along its normal, shows about 0.5 and more.
  double fit_residual = 0.0;
  /// The network's and the volume term's homogenised moduli, fitted back from their tensor:
  /// how close the model comes to E and nu.
  double effective_young_kpa = 0.0, effective_poisson = 0.0;
};

/// Checks E and nu: throws lamina::Error (kInvalidInput) naming the bad one.
void check_elastic_material(const ElasticMaterial& material);

/// Spring constants for `model` from E and nu.
/// @param[in]  model      its rest positions, layers, springs and lumped masses (the masses and
///                        density give each node's share of the volume)
/// @param[in]  material   E and nu
/// @param[out] stiffness_n_per_m  one constant per spring, N/m (= mN/mm), > 0
/// @return the fitted constants, the volume term's modulus and how well the fit holds
SpringIdentification identify_springs(const Model& model, const ElasticMaterial& material,
                                      std::vector<double>& stiffness_n_per_m);

}  // namespace lamina::model
