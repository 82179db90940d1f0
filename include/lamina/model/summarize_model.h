#pragma once
/// \file
/// A model's vital statistics: what `lamina build` and `lamina info` print.

#include <cstdint>
#include <string>
#include <vector>

#include "lamina/geometry/measure_tets.h"
#include "lamina/geometry/mesh_measures.h"
#include "lamina/model/build_model.h"
#include "lamina/model/layer_normals.h"
#include "lamina/model/model.h"

namespace lamina::model {

/// One layer's statistics.
struct LayerSummary {
  int32_t index = 0;
  geometry::MeshQuality quality;   ///< closed, manifold, components, volume, edges, angles
  bool self_intersecting = false;  ///< any two triangles cross
  bool nested = true;              ///< strictly inside the layer outside it (true for the skin)
  double min_gap_mm = 0.0;         ///< closest approach to the layer outside it
};

/// One surface carried by the tetrahedra (Model::embedded).
struct EmbeddedSummary {
  std::string name;
  SurfaceRole role = SurfaceRole::kStructure;
  int32_t label = 0;
  int64_t vertices = 0, faces = 0;
  int32_t outside = 0;  ///< vertices in no tetrahedron at rest
  int32_t offset = 0;   ///< those so far out that they follow by a rest offset
  /// The largest sum of |weights|: no vertex moves more than this many times the largest motion
  /// of its tetrahedron's nodes (at most kMaxAmplification)
  double max_amplification = 0.0;
  double volume_ml = 0.0;  ///< enclosed volume at rest
  bool closed = false;     ///< every edge in exactly two triangles (a surface that encloses)
  bool manifold = false;   ///< and consistently oriented, one fan per vertex
};

/// The whole model's statistics.
/// A vessel tree the model carries (Model::trees).
struct TreeSummary {
  std::string name;
  geometry::VesselTreeKind kind = geometry::VesselTreeKind::kPortal;
  int32_t roots = 0, branches = 0, seeds = 0, bridged_gaps = 0;
  double unrooted_mm = 0.0;
};

struct ModelSummary {
  int64_t nodes = 0;
  int64_t springs = 0, intra_layer_springs = 0, inter_layer_springs = 0;
  int64_t volume_springs = 0;     ///< tetrahedron edges that are no layer's edge
  int64_t interior_nodes = 0;     ///< nodes on no layer (inside the tetrahedra)
  geometry::TetQuality tets;      ///< count 0 when the layers are joined by links
  int32_t spring_components = 0;  ///< connected components of the spring network (1 = one body)
  double total_mass_kg = 0.0;
  int32_t locality = 0;
  int64_t ring_entries = 0;  ///< total stored ring members (CSR size)
  double min_rest_length_mm = 0.0, max_rest_length_mm = 0.0;
  std::vector<LayerSummary> layers;
  std::vector<EmbeddedSummary> embedded;  ///< the display skin and structures, in model order
  std::vector<TreeSummary> trees;         ///< the vessel trees, in model order
};

/// One layer as a standalone mesh (vertex indices local to the layer), at rest or at positions x
/// (#nodes by 3, mm).
SurfaceMesh layer_mesh(const Model& model, int32_t layer);
SurfaceMesh layer_mesh(const Model& model, int32_t layer, const Eigen::MatrixX3d& x);

/// Measures a model: per-layer mesh quality (with CGAL self-intersection and nesting checks),
/// spring counts and connectivity, tetrahedron quality, mass.
/// @param[in] model  the model
/// @param[in] build  the report of the build that made `model`, or nullptr. build_model() has
///   already checked self-intersection and nesting (it fails otherwise), so with a report those
///   CGAL checks are not run again and the gaps are taken from it.
ModelSummary summarize_model(const Model& model, const BuildReport* build = nullptr);

}  // namespace lamina::model
