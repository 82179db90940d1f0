#pragma once
/// \file
/// A vessel graph rooted where its trees leave the organ (issue 63): the portal vein's trunk at
/// the hilum, the hepatic veins where they reach the vena cava. Every branch then has a flow
/// direction and a parent, so that what lies downstream (portal) or upstream (hepatic) of a
/// divided branch is known.

#include <cstdint>
#include <string>
#include <vector>

#include "lamina/core/grid.h"
#include "lamina/geometry/vessel_graph.h"

namespace lamina::geometry {

struct VesselTree {
  /// The graph, with a node added where a gap was bridged onto a branch's middle and a branch
  /// (without voxels) for each gap bridged.
  VesselGraph graph;
  std::vector<int32_t> roots;  ///< per tree of the forest: its root node
  /// Per branch: the node nearer its root (a or b), -1 for a branch in no tree.
  std::vector<int32_t> from_node;
  /// Per branch: the branch that reaches its from_node, -1 for a branch leaving a root or in
  /// no tree.
  std::vector<int32_t> parent;
  /// Per node: the branch its shortest path from the root arrives by, -1 for a root or a node
  /// in no tree (a loop's other branches reach it too: they are its leaves).
  std::vector<int32_t> reached_by;
  std::vector<int32_t> order;  ///< the branches in a tree, each after its parent
  int32_t bridged_gaps = 0;    ///< gaps between pieces of the mask joined
  /// Centreline in pieces that reach no root (blobs, pieces beyond the largest gap bridged):
  /// in no tree, their territory goes to the nearest branch that is.
  double unrooted_mm = 0.0;
  /// Roots at VesselTreeOptions::outlet, among `roots` (the others at the organ's outside).
  int32_t outlet_roots = 0;
};

struct VesselTreeOptions {
  /// A piece's end is joined to the nearest centreline of another piece within this distance
  /// plus the end's radius (gaps of real segmentations).
  double max_gap_mm = 5.0;
  /// A piece with less centreline than this is a blob when no root is found for it, else a
  /// tree of its own is looked for.
  double least_tree_mm = 20.0;
  /// Where the trees drain or come from, on the organ's grid (the vena cava for the hepatic
  /// veins): a piece that reaches it (within its widest branch's radius and two voxels) is
  /// rooted at its widest node there; null, or a piece that does not: at the organ's outside.
  const Mask* outlet = nullptr;
};

/// Joins each piece's ends (nodes of one branch) to the nearest centreline of another piece within
/// `max_gap_mm` plus the end's radius, nearest gaps first, each pair of pieces once: a branch
/// without voxels, onto a node or onto a new node splitting a branch. Returns the gaps bridged.
int32_t bridge_gaps(VesselGraph& graph, double max_gap_mm);

/// Roots `graph` where its vessels leave `organ` (or reach options.outlet): for each connected
/// piece (after the gaps are bridged), the node nearest the organ's outside (within its widest
/// branch's radius and two voxels) whose widest branch is the widest; then each branch's flow
/// direction by the shortest path along the centrelines from the root (a loop is opened where the
/// two ways meet).
/// @param[in] graph  vessel_graph()'s
/// @param[in] organ  the organ's mask, on the graph's grid or a crop of it (same spacing and axes)
/// @param[in] name   the vessel's name, for the error
/// \note Throws lamina::Error (kInvalidInput) naming `name` when no piece has a root ("no root
///   found: the vessel does not reach the organ's surface").
VesselTree vessel_tree(VesselGraph graph, const Mask& organ, const std::string& name,
                       const VesselTreeOptions& options = {});

}  // namespace lamina::geometry
