#include "link_layers.h"

#include <algorithm>
#include <nanoflann.hpp>

namespace lamina::model {
namespace {

using Points = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using Tree = nanoflann::KDTreeEigenMatrixAdaptor<Points, 3, nanoflann::metric_L2_Simple>;

Points layer_points(const Model& m, const ModelLayer& layer) {
  return m.X.middleRows(layer.first_node, layer.node_count);
}

// Adds links from every node of `from` to its k nearest nodes of `to`.
void link_to(const Model& m, const ModelLayer& from, const ModelLayer& to, const Tree& tree,
             int32_t k, std::vector<std::pair<int32_t, int32_t>>& out) {
  const int32_t kk = std::min(k, to.node_count);
  std::vector<Eigen::Index> idx(static_cast<size_t>(kk));
  std::vector<double> d2(static_cast<size_t>(kk));
  for (int32_t v = 0; v < from.node_count; ++v) {
    const int32_t a = from.first_node + v;
    const double q[3] = {m.X(a, 0), m.X(a, 1), m.X(a, 2)};
    tree.query(q, static_cast<size_t>(kk), idx.data(), d2.data());
    for (int32_t n = 0; n < kk; ++n) {
      const int32_t b = to.first_node + static_cast<int32_t>(idx[n]);
      out.emplace_back(std::min(a, b), std::max(a, b));
    }
  }
}

}  // namespace

std::vector<std::pair<int32_t, int32_t>> link_layers(const Model& model, int32_t links) {
  std::vector<std::pair<int32_t, int32_t>> out;
  for (int32_t k = 0; k + 1 < model.layer_count(); ++k) {
    const ModelLayer& outer = model.layers[k];
    const ModelLayer& inner = model.layers[k + 1];
    const Points po = layer_points(model, outer), pi = layer_points(model, inner);
    const Tree to_outer(3, std::cref(po), 16), to_inner(3, std::cref(pi), 16);
    link_to(model, inner, outer, to_outer, links, out);  // each node to the next layer out
    link_to(model, outer, inner, to_inner, links, out);  // and to the next layer in
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

}  // namespace lamina::model
