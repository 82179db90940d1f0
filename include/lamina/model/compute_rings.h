#pragma once
/// \file
/// The paper's hierarchical neighbourhood structure: BFS rings of every node within its layer.

#include "lamina/model/model.h"

namespace lamina::model {

/// Computes rings 0..locality-1 of every node by breadth-first search over its own layer's
/// mesh edges (intra-layer springs). Deterministic; each ring is sorted ascending.
/// @param[in] model     nodes, layers and springs (model.rings is ignored)
/// @param[in] locality  N >= 1: the number of rings kept per node
/// @return CSR rings; memory ~ #nodes * (average nodes within N-1 hops) * 4 bytes
Rings compute_rings(const Model& model, int32_t locality);

/// Rings again after the nodes changed in a few places (a cut): node v's rings are those of
/// node previous_node[v] in `previous`, renumbered by `renumber`, where keep[v] (its rings reach
/// no node that changed), and searched again otherwise. The same result as compute_rings() when
/// `keep` is true only where that holds.
/// @param[in] model          the changed model (nodes, layers, springs)
/// @param[in] previous       the rings before the change (its locality is kept)
/// @param[in] previous_node  #model nodes: the node each was before
/// @param[in] renumber       #previous nodes: the node each is now, monotone
/// @param[in] keep           #model nodes: 1 where the previous rings still hold
Rings update_rings(const Model& model, const Rings& previous,
                   const std::vector<int32_t>& previous_node, const std::vector<int32_t>& renumber,
                   const std::vector<uint8_t>& keep);

}  // namespace lamina::model
