#pragma once
/// \file
/// After a resection: the model without the pieces a cut separated on one side of a plane (the
/// viewer's X takes the resected part away; the remnant is simulated, touched and grasped on).

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "lamina/model/model.h"

namespace lamina::model {

/// The pieces of the tetrahedra `take` marks (#T; all when empty), joined where they share a
/// node (a cut's copies share none across it): per node, a representative node of its piece
/// (the piece's smallest node index), -1 for the nodes of no such tetrahedron.
std::vector<int32_t> tet_pieces(const Eigen::MatrixX4i& T, int32_t nodes,
                                const std::vector<uint8_t>& take = {});

/// The nodes of the pieces on one side of a plane: the tetrahedra joined where they share a node
/// (a cut's copies share none across it), each piece on the side of its volume's centroid.
/// @return #nodes, 1 for the nodes of the pieces whose centroid is in front of the plane
///   (`front`) or behind it (!front)
std::vector<uint8_t> nodes_of_pieces_on_side(const Model& model, const Eigen::Vector3d& point,
                                             const Eigen::Vector3d& normal, bool front);

/// The model restricted to the nodes `keep` marks: those nodes (in order, so every layer stays a
/// contiguous range), the tetrahedra, springs and layer triangles all of whose nodes are kept,
/// and the embedded surfaces' vertices whose tetrahedron's corners are all kept (with the
/// triangles all of whose vertices are). Rings are computed again to the model's locality.
/// @param[out] new_index  #old nodes: each kept node's index in the result, -1 for the others
/// \note Throws lamina::Error (kInvalidInput) when nothing would be kept or `keep` has the
///   wrong size.
Model keep_nodes(const Model& model, const std::vector<uint8_t>& keep,
                 std::vector<int32_t>& new_index);

}  // namespace lamina::model
