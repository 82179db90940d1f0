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
/// tissue is sampled at the tetrahedra's centroids, or at their eight equal parts' where their
/// longest edge exceeds kSampleEdgeMm (the paper-size model's tetrahedra, far coarser than the
/// segmentation's voxels). (Measured on the planning phantom against the
/// voxels' plan at five planes: 1-5% with centroids only, 1-5% with 8 or 64 parts; the rest is
/// the trees' own difference, so finer parts only cost: 64 parts made 32 ms a plane at 22k
/// nodes.)
struct ModelTerritories {
  int64_t tets = 0;                   ///< the tetrahedra they were made for
  std::vector<uint8_t> level;         ///< per tetrahedron: its split's level, 0 or 1
  std::vector<int64_t> first_sample;  ///< per tetrahedron: its first sample; #tets + 1 entries
  std::vector<double> sample_ml;      ///< per sample: its share of its tetrahedron's volume, mL
  /// Per tree, per sample: the seed nearest it at rest.
  std::vector<std::vector<int32_t>> sample_seed;
  /// The trees' flows, each branch's territory its samples' volume.
  std::vector<geometry::TreeFlow> flows;
  int64_t samples() const { return static_cast<int64_t>(sample_ml.size()); }
};

/// A tetrahedron whose longest edge exceeds this is sampled by its eight parts' centroids.
inline constexpr double kSampleEdgeMm = 6.0;

/// The barycentric weights of the samples of a tetrahedron split to `level` (0 or 1: 8^level
/// rows).
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

/// Per branch of `flow`: its sector, the ancestor two generations below its root's branch (or
/// itself when shallower): the level of Couinaud's sectors, what a picture colours by.
std::vector<int32_t> portal_sectors(const geometry::TreeFlow& flow);

/// What a surface's vertex shows of a plan (the viewer's and the web page's colours).
enum SurfaceFunction : uint8_t {
  kOnResectedSide = 0,  ///< beyond the plane: not the remnant's
  // 1..8: functional, in its portal sector's colour (sector id mod 8, + 1)
  kShownDevascularized = 9,
  kShownCongested = 10,
  kShownBoth = 11,
  kFunctionalPlain = 12,  ///< functional, no portal tree to colour it by
};

/// Per vertex of a surface the model carries, at positions P: its SurfaceFunction under the plan
/// whose functional remnant is `fr` (the plane p0, normal, the remnant's side).
/// @param[in] seed_of  per tree (Model::trees order), per vertex: the seed nearest its rest
///                     position (nearest_seeds())
std::vector<uint8_t> surface_function(const Model& model,
                                      const std::vector<std::vector<int32_t>>& seed_of,
                                      const geometry::FunctionalRemnant& fr,
                                      const Eigen::MatrixX3d& P, const Eigen::Vector3d& p0,
                                      const Eigen::Vector3d& normal, bool remnant_in_front);

}  // namespace lamina::model
