#pragma once
/// \file
/// The multi-layer volumetric mass-spring model: immutable after model::build_model().
/// Units: mm, kg, s (so stiffness is in mN/mm = N/m).

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "lamina/core/surface_role.h"
#include "lamina/geometry/tree_flow.h"

namespace lamina {

/// What a spring joins.
enum class SpringKind : uint8_t {
  kIntraLayer = 0,  ///< an edge of one layer's triangle mesh
  kInterLayer = 1,  ///< a link between a vertex and a near vertex on the neighbouring layer
  kVolume = 2,      ///< an edge of the tetrahedra inside the organ that is no layer's edge
};

/// Model::layer_of of a node that lies on no layer: a point the tetrahedral mesher added inside
/// a shell or the core.
inline constexpr int32_t kInteriorNode = -1;

/// All springs, structure-of-arrays (the simulation streams through these).
struct Springs {
  std::vector<int32_t> i, j;              ///< node indices, i < j
  std::vector<double> rest_length_mm;     ///< > 0
  std::vector<double> stiffness_n_per_m;  ///< Hooke constant, N/m (= mN/mm), > 0
  std::vector<SpringKind> kind;
  /// Per spring, the share of its edge's tetrahedra's material it carries after a cut divided
  /// some of them (model::cut_tetrahedra; a constant given for every spring is scaled by it).
  /// Empty: every spring carries all (an uncut model).
  std::vector<double> share;

  size_t size() const { return i.size(); }
  /// Spring e's share (1 on an uncut model).
  double share_of(size_t e) const { return share.empty() ? 1.0 : share[e]; }
};

/// One nested surface. Its nodes are the contiguous range [first_node, first_node + node_count).
struct ModelLayer {
  int32_t first_node = 0;
  int32_t node_count = 0;
  Eigen::MatrixX3i F;  ///< #F by 3 triangles in GLOBAL node indices, outward winding
};

/// The tetrahedra that fill the organ: each shell between neighbouring layers and the core
/// inside the deepest layer. Conforming: every layer triangle is a face of a tetrahedron, and the
/// tetrahedra's edges are the model's springs.
struct Tets {
  Eigen::MatrixX4i T;  ///< #T by 4 node indices, positively oriented at rest
  std::vector<int32_t>
      region;  ///< #T: k = the shell just inside layer k (the core for the deepest)
  /// #T: the share of its rest volume's material each carries, in (0, 1]: below 1 for the two
  /// copies a cut made of a tetrahedron (model::cut_tetrahedra, the virtual node algorithm), whose
  /// energies and masses are scaled by it. Empty: every share is 1 (an uncut model).
  std::vector<double> share;
  /// #T after a cut: which corners' material each carries (bit k: corner k; 15: all). A copy's
  /// corners beyond the cut are virtual nodes: they only carry its shape. Empty: all (uncut).
  std::vector<uint8_t> material;

  int64_t size() const { return T.rows(); }
  /// Tetrahedron t's material corners (15 on an uncut model).
  uint8_t material_of(int64_t t) const {
    return material.empty() ? uint8_t{15} : material[static_cast<size_t>(t)];
  }
  /// Tetrahedron t's share (1 on an uncut model).
  double share_of(int64_t t) const { return share.empty() ? 1.0 : share[static_cast<size_t>(t)]; }
};

/// The paper's hierarchical neighbourhood matrix, stored as CSR: for node v and ring r in
/// [0, locality), ring r of v is members[offsets[v * locality + r], offsets[v * locality + r + 1]).
/// Ring 0 is {v}; ring r holds the nodes of v's own layer at breadth-first (edge-hop) distance r.
struct Rings {
  int32_t locality = 0;          ///< N: rings 0..N-1 are stored
  std::vector<int64_t> offsets;  ///< #nodes * locality + 1 entries
  std::vector<int32_t> members;  ///< node indices, each ring sorted ascending

  /// Number of nodes in ring r of node v.
  int64_t ring_size(int32_t v, int32_t r) const {
    const size_t at = static_cast<size_t>(v) * locality + r;
    return offsets[at + 1] - offsets[at];
  }
  /// Pointer to the first node of ring r of node v (ring_size(v, r) entries).
  const int32_t* ring(int32_t v, int32_t r) const {
    return members.data() + offsets[static_cast<size_t>(v) * locality + r];
  }
};

/// A surface the tetrahedra carry (a fine display skin, a vessel, a tumour): each vertex keeps
/// the four corners of its rest tetrahedron and its barycentric weights there, so that at node
/// positions x it lies at sum_c weights(v, c) x(corners(v, c)) + offsets(v)
/// (model::embedded_positions). A vertex in no tetrahedron follows a near one, the one it is
/// least outside of: its weights then extrapolate (some are negative, all still summing to 1),
/// but never so far that the sum of their sizes exceeds kMaxAmplification. A vertex farther out
/// (a vessel's trunk beyond the organ) takes the weights of a point between it and its
/// tetrahedron's nearest point, and a fixed rest-space offset to itself: it follows that point
/// by translation, moving at most kMaxAmplification times as far as the tetrahedron's nodes.
struct EmbeddedSurface {
  std::string name;  ///< "display_skin", "wound", or the structure's name: for people only
  /// What it is: every consumer (cuts, plans, colours, the viewer, the stream) reads this, never
  /// the name or the label
  SurfaceRole role = SurfaceRole::kStructure;
  /// The segmentation label it came from (0: the organ's own skin, a wound, or a separate mask's
  /// every non-zero voxel): where it came from, not what it is
  int32_t label = 0;
  Eigen::MatrixX3d V;        ///< rest positions, mm
  Eigen::MatrixX3i F;        ///< triangles (rows of V), outward winding
  Eigen::MatrixX4i corners;  ///< per vertex: the nodes of its tetrahedron
  Eigen::MatrixX4d weights;  ///< per vertex: their barycentric weights, summing to 1
  /// Per vertex: the rest-space offset added to W x, mm; empty when no vertex has one (every
  /// vertex inside the tetrahedra or near them). Zero rows for the vertices without.
  Eigen::MatrixX3d offsets;
  int32_t outside = 0;  ///< vertices in no tetrahedron at rest (they follow the nearest)
};

/// No embedded vertex moves more than this many times the largest motion of its tetrahedron's
/// nodes: the bound on the sum of |weights| (|sum_c w_c d_c| <= sum_c |w_c| max_c |d_c|).
inline constexpr double kMaxAmplification = 2.0;

/// A vessel tree the model carries (issue 63): its centreline's seeds, embedded in the rest
/// tetrahedra like a surface's vertices (so they follow the organ), with the flow between them;
/// the tissue each branch feeds or drains is the nearest seed's (model::model_territories).
struct ModelVesselTree {
  geometry::TreeFlow flow;
  int32_t label = 0;  ///< the segmentation label it came from (0: a separate mask)
  /// The seeds as points without triangles: rest positions, corners, weights (and offsets for
  /// a trunk beyond the organ); seeds.name is the tree's, seeds.outside is 0 (not kept).
  EmbeddedSurface seeds;
  /// Per seed: 1 when it lies in the organ (only there does a resection take it).
  std::vector<uint8_t> in_organ;
};

/// The model. Nodes are ordered by layer: layer 0 (the skin) first; the interior nodes of the
/// tetrahedra (on no layer) come last.
struct Model {
  Eigen::MatrixX3d X;              ///< #nodes by 3 rest positions, mm (column-major = SoA)
  std::vector<double> mass_kg;     ///< #nodes lumped masses, kg, > 0
  std::vector<int32_t> layer_of;   ///< #nodes layer index of each node, or kInteriorNode
  std::vector<uint8_t> fixed;      ///< #nodes, 1 = held in place (boundary condition)
  std::vector<ModelLayer> layers;  ///< layer 0 = skin, then inward
  Springs springs;
  Tets tets;  ///< empty for a model whose layers are joined by links only
  Rings rings;
  /// Surfaces carried by the tetrahedra, drawn (and touched) instead of, or inside, the skin.
  std::vector<EmbeddedSurface> embedded;
  /// The portal and hepatic-vein trees of structures so named (empty for others): what the
  /// functional remnant of a plan on the model follows.
  std::vector<ModelVesselTree> trees;
  double density_kg_per_mm3 = 1.06e-6;  ///< used to lump the masses (liver: 1.06 g/cm^3)
  std::string source;                   ///< what it was built from (path or "built-in phantom")

  int32_t node_count() const { return static_cast<int32_t>(X.rows()); }
  int32_t layer_count() const { return static_cast<int32_t>(layers.size()); }
  /// Nodes on a layer: [0, surface_node_count()); interior nodes follow.
  int32_t surface_node_count() const {
    return layers.empty() ? 0 : layers.back().first_node + layers.back().node_count;
  }
  bool has_tets() const { return tets.size() > 0; }
};

}  // namespace lamina
