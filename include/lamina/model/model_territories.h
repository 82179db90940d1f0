#pragma once
/// \file
/// The territories of the vessel trees a model carries (Model::trees, issue 63), and the
/// functional remnant of a plan on the model at any shape: each sample of the tissue belongs to
/// the seed nearest it at rest (as each voxel of the segmentation belongs to the nearest
/// centreline voxel), and a seed the resection takes cuts off every seed downstream of it.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "lamina/geometry/functional_remnant.h"
#include "lamina/model/model.h"

namespace lamina::model {

/// Made once per topology (a cut makes them again: `tets` says for which), asked per plane. The
/// tissue is sampled finer than the tetrahedra: each is split into 8^level equal parts (level
/// 0 to 2, their edges at most kSampleEdgeMm where the tetrahedron allows), a sample at each
/// part's centroid, carried by the tetrahedron's barycentric weights.
struct ModelTerritories {
  int64_t tets = 0;                   ///< the tetrahedra they were made for
  std::vector<uint8_t> level;         ///< per tetrahedron: its split's level
  std::vector<int64_t> first_sample;  ///< per tetrahedron: its first sample; #tets + 1 entries
  std::vector<double> sample_ml;      ///< per sample: its share of its tetrahedron's volume, mL
  /// Per tree, per sample: the seed nearest it at rest.
  std::vector<std::vector<int32_t>> sample_seed;
  /// The trees' flows, each branch's territory its samples' volume.
  std::vector<geometry::TreeFlow> flows;
  int64_t samples() const { return static_cast<int64_t>(sample_ml.size()); }
};

/// The longest edge a tetrahedron's parts are split to (when 64 parts reach it).
inline constexpr double kSampleEdgeMm = 3.0;

/// The barycentric weights of the samples of a tetrahedron split to `level` (8^level rows).
const std::vector<Eigen::Vector4d>& sample_weights(int level);

/// The territories of `model`'s trees (none for a model without trees or tetrahedra).
ModelTerritories model_territories(const Model& model);

/// Per point (rest positions, mm): the nearest seed of `tree` (for colouring a surface by its
/// territories).
std::vector<int32_t> nearest_seeds(const ModelVesselTree& tree, const Eigen::MatrixX3d& points);

/// The functional remnant of the model at positions x cut along the plane (p0, normal) with the
/// remnant on the side `remnant_in_front` says: the seeds in the organ on the other side are
/// taken; the samples on the remnant's side at x are its tissue.
/// @param[in] remnant_ml  the geometric remnant's volume (the lost volumes are its share)
/// \note Throws lamina::Error (kInvalidInput) naming the model's source when `territories` were
///   made for other tetrahedra.
geometry::FunctionalRemnant functional_on_model(const Model& model,
                                                const ModelTerritories& territories,
                                                const Eigen::MatrixX3d& x,
                                                const Eigen::Vector3d& p0,
                                                const Eigen::Vector3d& normal,
                                                bool remnant_in_front, double remnant_ml);

}  // namespace lamina::model
