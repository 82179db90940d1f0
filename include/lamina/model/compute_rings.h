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

}  // namespace lamina::model
