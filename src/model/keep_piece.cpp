// nodes_of_pieces_on_side and keep_nodes (keep_piece.h).
#include "lamina/model/keep_piece.h"

#include <Eigen/Geometry>
#include <numeric>

#include "lamina/core/error.h"
#include "lamina/model/compute_rings.h"

namespace lamina::model {
namespace {

// The rows of `v` that `keep` marks, in order.
template <class T>
std::vector<T> kept(const std::vector<T>& v, const std::vector<uint8_t>& keep) {
  if (v.empty()) return v;
  std::vector<T> out;
  for (size_t i = 0; i < v.size(); ++i)
    if (keep[i]) out.push_back(v[i]);
  return out;
}

}  // namespace

std::vector<int32_t> tet_pieces(const Eigen::MatrixX4i& T, int32_t nodes,
                                const std::vector<uint8_t>& take) {
  std::vector<int32_t> parent(static_cast<size_t>(nodes));
  std::iota(parent.begin(), parent.end(), 0);
  const auto find = [&parent](int32_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  std::vector<uint8_t> used(parent.size(), 0);
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    if (!take.empty() && !take[static_cast<size_t>(t)]) continue;
    used[T(t, 0)] = 1;
    for (int k = 1; k < 4; ++k) {
      used[T(t, k)] = 1;
      const int32_t a = find(T(t, 0)), b = find(T(t, k));
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  }
  std::vector<int32_t> piece(parent.size(), -1);
  for (int32_t n = 0; n < nodes; ++n)
    if (used[n]) piece[n] = find(n);
  return piece;
}

std::vector<uint8_t> nodes_of_pieces_on_side(const Model& model, const Eigen::Vector3d& point,
                                             const Eigen::Vector3d& normal, bool front) {
  const Eigen::MatrixX4i& T = model.tets.T;
  const std::vector<int32_t> piece = tet_pieces(T, model.node_count());
  // Each piece's volume and first moment about the plane's point, along its normal.
  std::vector<double> volume(piece.size(), 0.0), moment(piece.size(), 0.0);
  const Eigen::MatrixX3d& X = model.X;
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    const Eigen::Vector3d a = X.row(T(t, 0)), b = X.row(T(t, 1)), c = X.row(T(t, 2)),
                          d = X.row(T(t, 3));
    const double v = std::abs((b - a).dot((c - a).cross(d - a))) / 6.0 * model.tets.share_of(t);
    const int32_t r = piece[T(t, 0)];
    volume[r] += v;
    moment[r] += v * (((a + b + c + d) / 4.0 - point).dot(normal));
  }
  std::vector<uint8_t> out(piece.size(), 0);
  for (size_t n = 0; n < piece.size(); ++n)
    if (piece[n] >= 0 && volume[piece[n]] > 0.0) out[n] = (moment[piece[n]] > 0.0) == front;
  return out;
}

Model keep_nodes(const Model& m, const std::vector<uint8_t>& keep,
                 std::vector<int32_t>& new_index) {
  const int32_t n = m.node_count();
  if (static_cast<int32_t>(keep.size()) != n)
    throw invalid_input("keep_nodes", "one flag per node expected");
  new_index.assign(static_cast<size_t>(n), -1);
  int32_t count = 0;
  for (int32_t i = 0; i < n; ++i)
    if (keep[i]) new_index[i] = count++;
  if (count == 0) throw invalid_input("keep_nodes", "no node would be kept");
  const auto all_kept = [&](auto row, int corners) {
    for (int c = 0; c < corners; ++c)
      if (new_index[row(c)] < 0) return false;
    return true;
  };

  Model out;
  out.density_kg_per_mm3 = m.density_kg_per_mm3;
  out.source = m.source;
  out.X.resize(count, 3);
  for (int32_t i = 0; i < n; ++i)
    if (new_index[i] >= 0) out.X.row(new_index[i]) = m.X.row(i);
  out.mass_kg = kept(m.mass_kg, keep);
  out.layer_of = kept(m.layer_of, keep);
  out.fixed = kept(m.fixed, keep);
  for (const ModelLayer& l : m.layers) {
    ModelLayer k;
    for (int32_t i = 0; i < l.first_node; ++i) k.first_node += keep[i] ? 1 : 0;
    for (int32_t i = l.first_node; i < l.first_node + l.node_count; ++i) k.node_count += keep[i];
    std::vector<Eigen::Vector3i> tris;
    for (Eigen::Index f = 0; f < l.F.rows(); ++f)
      if (all_kept([&](int c) { return l.F(f, c); }, 3))
        tris.emplace_back(new_index[l.F(f, 0)], new_index[l.F(f, 1)], new_index[l.F(f, 2)]);
    k.F.resize(static_cast<Eigen::Index>(tris.size()), 3);
    for (size_t t = 0; t < tris.size(); ++t) k.F.row(static_cast<Eigen::Index>(t)) = tris[t];
    out.layers.push_back(std::move(k));
  }
  // Springs.
  std::vector<uint8_t> spring(m.springs.size());
  for (size_t e = 0; e < m.springs.size(); ++e)
    spring[e] = new_index[m.springs.i[e]] >= 0 && new_index[m.springs.j[e]] >= 0;
  out.springs.i = kept(m.springs.i, spring);
  out.springs.j = kept(m.springs.j, spring);
  for (int32_t& i : out.springs.i) i = new_index[i];
  for (int32_t& j : out.springs.j) j = new_index[j];
  out.springs.rest_length_mm = kept(m.springs.rest_length_mm, spring);
  out.springs.stiffness_n_per_m = kept(m.springs.stiffness_n_per_m, spring);
  out.springs.kind = kept(m.springs.kind, spring);
  out.springs.share = kept(m.springs.share, spring);
  // Tetrahedra.
  std::vector<uint8_t> tet(static_cast<size_t>(m.tets.size()));
  int64_t tets = 0;
  for (Eigen::Index t = 0; t < m.tets.T.rows(); ++t)
    tets += tet[t] = all_kept([&](int c) { return m.tets.T(t, c); }, 4);
  out.tets.T.resize(tets, 4);
  for (Eigen::Index t = 0, k = 0; t < m.tets.T.rows(); ++t) {
    if (!tet[t]) continue;
    for (int c = 0; c < 4; ++c) out.tets.T(k, c) = new_index[m.tets.T(t, c)];
    ++k;
  }
  out.tets.region = kept(m.tets.region, tet);
  out.tets.share = kept(m.tets.share, tet);
  out.tets.material = kept(m.tets.material, tet);
  // Embedded surfaces: the vertices carried by kept tetrahedra's corners.
  for (const EmbeddedSurface& e : m.embedded) {
    EmbeddedSurface k;
    k.name = e.name;
    k.role = e.role;
    k.label = e.label;
    std::vector<int32_t> vindex(static_cast<size_t>(e.V.rows()), -1);
    int32_t vcount = 0;
    for (Eigen::Index v = 0; v < e.V.rows(); ++v)
      if (all_kept([&](int c) { return e.corners(v, c); }, 4)) vindex[v] = vcount++;
    if (vcount == 0) continue;
    k.V.resize(vcount, 3);
    k.corners.resize(vcount, 4);
    k.weights.resize(vcount, 4);
    if (e.offsets.rows() > 0) k.offsets.resize(vcount, 3);
    for (Eigen::Index v = 0; v < e.V.rows(); ++v) {
      const int32_t w = vindex[v];
      if (w < 0) continue;
      k.V.row(w) = e.V.row(v);
      for (int c = 0; c < 4; ++c) k.corners(w, c) = new_index[e.corners(v, c)];
      k.weights.row(w) = e.weights.row(v);
      if (e.offsets.rows() > 0) k.offsets.row(w) = e.offsets.row(v);
      // A vertex outside every tetrahedron extrapolates: some weight is negative.
      k.outside += e.weights.row(v).minCoeff() < 0.0 ? 1 : 0;
    }
    std::vector<Eigen::Vector3i> tris;
    for (Eigen::Index f = 0; f < e.F.rows(); ++f)
      if (vindex[e.F(f, 0)] >= 0 && vindex[e.F(f, 1)] >= 0 && vindex[e.F(f, 2)] >= 0)
        tris.emplace_back(vindex[e.F(f, 0)], vindex[e.F(f, 1)], vindex[e.F(f, 2)]);
    k.F.resize(static_cast<Eigen::Index>(tris.size()), 3);
    for (size_t t = 0; t < tris.size(); ++t) k.F.row(static_cast<Eigen::Index>(t)) = tris[t];
    out.embedded.push_back(std::move(k));
  }
  // The vessel trees whose every seed stays (a seed lost would break the flow through it).
  for (const ModelVesselTree& tree : m.trees) {
    const EmbeddedSurface& e = tree.seeds;
    bool all = true;
    for (Eigen::Index v = 0; v < e.V.rows() && all; ++v)
      all = all_kept([&](int c) { return e.corners(v, c); }, 4);
    if (!all) continue;
    ModelVesselTree k = tree;
    for (Eigen::Index v = 0; v < e.V.rows(); ++v)
      for (int c = 0; c < 4; ++c) k.seeds.corners(v, c) = new_index[e.corners(v, c)];
    out.trees.push_back(std::move(k));
  }
  out.rings = compute_rings(out, std::max(1, m.rings.locality));
  return out;
}

}  // namespace lamina::model
