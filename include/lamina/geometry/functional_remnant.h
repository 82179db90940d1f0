#pragma once
/// \file
/// The functional remnant (issue 63): the remnant's tissue that keeps both its portal inflow and
/// its hepatic-vein outflow after a resection. Tissue whose portal branch the surface divides
/// upstream of it is devascularized; tissue whose hepatic vein it divides downstream of it (on
/// the way to the vena cava) is congested (Lang et al., JAMA Surgery 2006; MeVis's risk
/// analysis).

#include <cstdint>
#include <string>
#include <vector>

#include "lamina/core/grid.h"
#include "lamina/geometry/structure_names.h"
#include "lamina/geometry/tree_flow.h"
#include "lamina/geometry/tree_territories.h"

namespace lamina::geometry {

/// A vessel tree of the segmentation with its territories in the organ.
struct VascularTree {
  VesselTreeKind kind = VesselTreeKind::kPortal;
  int32_t label = 0;
  TreeTerritories territories;
};

/// The tree and territories of the vessel `vessel` (a mask on the organ's grid) in `organ`,
/// rooted where it reaches `outlet` when given (the vena cava, for the hepatic veins;
/// VesselTreeOptions::outlet), else where it leaves the organ.
/// `name` is the tree's (its territories' name); `source`, where it came from (the
/// segmentation's path; empty: none), leads its errors.
/// \note Throws lamina::Error (kInvalidInput) naming "source: name": no voxel of the vessel
///   inside the organ, no root found (vessel_tree()).
VascularTree vascular_tree(const Mask& organ, const Mask& vessel, const std::string& source,
                           const std::string& name, VesselTreeKind kind, int32_t label,
                           const Mask* outlet = nullptr);

/// A branch of a tree against a resection.
struct BranchFate {
  int32_t id = 0;       ///< the branch's index in its tree's graph
  int32_t parent = -1;  ///< the branch upstream of it, -1 at a root
  double length_mm = 0.0, radius_mm = 0.0;
  double territory_ml = 0.0;  ///< the organ's tissue it feeds or drains
  double remnant_ml = 0.0;    ///< of which in the remnant
  double lost_ml = 0.0;       ///< of which in the remnant but cut off from the root
  /// "kept" (its flow reaches the root), "divided" (the surface crosses it in the organ),
  /// "cut off" (downstream of a divided branch), "resected" (all of it on the resected side)
  std::string state;
};

/// A tree's part in the functional remnant.
struct TreeFate {
  std::string name;
  VesselTreeKind kind = VesselTreeKind::kPortal;
  int32_t roots = 0, bridged_gaps = 0;
  double unrooted_mm = 0.0;
  double lost_ml = 0.0;  ///< the remnant's tissue this tree no longer serves
  int32_t divided = 0;   ///< branches the surface divides
  std::vector<BranchFate> branches;
  /// Per seed: 1 while its flow still reaches the root (what a picture shades by).
  std::vector<uint8_t> connected;
};

struct FunctionalRemnant {
  bool portal = false, hepatic = false;  ///< which trees were assessed
  double devascularized_ml = 0.0;        ///< remnant tissue cut off from the portal root
  double congested_ml = 0.0;             ///< remnant tissue cut off from the hepatic roots
  double lost_ml = 0.0;                  ///< either
  // The three: the remnant's volume times the share of its voxels (by centre) they hold.
  double functional_ml = 0.0;  ///< the remnant less lost_ml
  std::vector<TreeFate> trees;
};

/// A tumour's vascular territory (issue 63): the branches whose territories hold its voxels, and
/// the smallest subtree holding them all (their nearest common ancestor's): what an anatomical
/// resection of the tumour takes.
struct TumourTerritory {
  std::string tree;               ///< the tree's name
  std::vector<int32_t> branches;  ///< feeding the tumour's voxels, by how many, most first
  int32_t subtree = -1;           ///< the common ancestor; -1 when they are in two trees
  double territory_ml = 0.0;      ///< the subtree's territory
};

/// The territory of a tumour whose voxels (on the organ's grid) are `voxels`, in `tree`.
TumourTerritory tumour_territory(const VascularTree& tree, const std::vector<int64_t>& voxels,
                                 double voxel_ml);

/// Each remnant voxel's function, for the label volume written beside the parts.
enum : uint8_t {
  kFunctional = 1,
  kDevascularized = 2,
  kCongested = 3,
  kDevascularizedCongested = 4
};

/// What the functional remnant needs of `tree`: its seeds' flow, its branches, their territories.
TreeFlow tree_flow(const VascularTree& tree, double voxel_ml);

/// The functional remnant of a resection that keeps the organ voxels `kept` marks (non-zero, on
/// the organ's grid) and takes the organ's others.
/// @param[in] remnant_ml  the geometric remnant's volume (split voxels exact)
/// @param[out] function   per voxel of the organ's grid: 0 outside the remnant, else kFunctional,
///   kDevascularized, kCongested or kDevascularizedCongested
FunctionalRemnant functional_remnant(const std::vector<VascularTree>& trees, const Mask& organ,
                                     const std::vector<uint8_t>& kept, double remnant_ml,
                                     std::vector<uint8_t>& function);

/// The organ's tissue as cells (its voxels, a model's tetrahedra), each with its nearest seed in
/// each tree: what the functional remnant counts, wherever the trees were carried.
struct TissueCells {
  /// Per tree (in the order of the flows), per cell: its nearest seed, -1 outside the organ.
  std::vector<const std::vector<int32_t>*> seed_of;
  /// Per cell: its volume, mL; null: `uniform_ml` each.
  const std::vector<double>* cell_ml = nullptr;
  double uniform_ml = 0.0;
};

/// The functional remnant over any cells: per tree, the seeds `blocked` says the resection takes
/// (non-zero), the cells `kept` says are the remnant's (non-zero).
/// @param[in] remnant_ml  the geometric remnant's volume: the lost volumes are its share of the
///   remnant's cells they hold, so that they never exceed it
/// @param[out] function   per cell: 0 outside the remnant, else kFunctional, ... as above
FunctionalRemnant functional_remnant(const std::vector<TreeFlow>& trees,
                                     const std::vector<std::vector<uint8_t>>& blocked,
                                     const TissueCells& cells, const std::vector<uint8_t>& kept,
                                     double remnant_ml, std::vector<uint8_t>& function);

}  // namespace lamina::geometry
