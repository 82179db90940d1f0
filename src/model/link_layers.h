#pragma once
/// \file
/// Springs between neighbouring layers, which turn nested shells into one volumetric body.

#include <cstdint>
#include <utility>
#include <vector>

#include "lamina/model/model.h"

namespace lamina::model {

/// For each pair of neighbouring layers (k, k+1), links every node of either layer to its
/// `links` nearest nodes on the other one (k-d tree queries, nanoflann). Duplicates removed.
/// @param[in] model  nodes (X) and layers
/// @param[in] links  nearest nodes per node and direction, >= 1
/// @return node pairs (i < j), sorted
std::vector<std::pair<int32_t, int32_t>> link_layers(const Model& model, int32_t links);

}  // namespace lamina::model
