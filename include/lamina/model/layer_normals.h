#pragma once
/// \file
/// Each node's outward normal on its own layer.

#include <Eigen/Core>

#include "lamina/model/model.h"

namespace lamina::model {

/// Each node's outward unit normal on its own layer at rest (area-weighted face normals;
/// #nodes by 3; (0, 0, 1) for a node on no triangle).
Eigen::MatrixX3d layer_normals(const Model& model);

}  // namespace lamina::model
