#pragma once
// A cut model's pieces and each fine surface's parts on them (the cut tests' checks of issue
// 47's surface split).

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <numeric>
#include <utility>
#include <vector>

#include "lamina/geometry/mesh_measures.h"
#include "lamina/model/model.h"

namespace lamina::test {

/// The surface's triangles, each by the piece its first vertex follows and its centroid (to
/// 1e-6 mm), sorted: two cuts that leave the same surface give the same list.
inline std::vector<std::array<int64_t, 4>> triangle_keys(const EmbeddedSurface& s,
                                                         const std::vector<int32_t>& piece) {
  std::vector<std::array<int64_t, 4>> out;
  for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
    const Eigen::Vector3d c =
        (s.V.row(s.F(f, 0)) + s.V.row(s.F(f, 1)) + s.V.row(s.F(f, 2))).transpose() / 3.0;
    out.push_back({piece[s.corners(s.F(f, 0), 0)], std::llround(c.x() * 1e6),
                   std::llround(c.y() * 1e6), std::llround(c.z() * 1e6)});
  }
  std::sort(out.begin(), out.end());
  return out;
}

/// Per node, its piece: the root of its connected part of the tetrahedra.
inline std::vector<int32_t> piece_of_nodes(const Model& m) {
  std::vector<int32_t> p(static_cast<size_t>(m.node_count()));
  std::iota(p.begin(), p.end(), 0);
  auto find = [&](int32_t a) {
    while (p[a] != a) a = p[a] = p[p[a]];
    return a;
  };
  for (Eigen::Index t = 0; t < m.tets.size(); ++t)
    for (int k = 1; k < 4; ++k) p[find(m.tets.T(t, k))] = find(m.tets.T(t, 0));
  for (auto& q : p) q = find(q);
  return p;
}

/// A fine surface of a cut model, by piece.
struct SurfaceParts {
  std::map<int32_t, double> volume;  ///< the volume each piece's part encloses, by piece
  int open_edges = 0;  ///< directed edges without exactly one twin within their piece's part
  int straddling = 0;  ///< triangles with corners on both sides of the plane x = plane_x
  int on_two = 0;      ///< triangles whose corners follow two pieces
  int on_cut = 0;      ///< vertices on the plane
};

/// `s`'s parts on the pieces `piece` (per node) gives, the cut at rest the plane x = plane_x.
inline SurfaceParts surface_parts(const EmbeddedSurface& s, const std::vector<int32_t>& piece,
                                  double plane_x) {
  SurfaceParts out;
  std::map<int32_t, std::vector<Eigen::Index>> faces;
  for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
    const int32_t p = piece[s.corners(s.F(f, 0), 0)];
    bool one = true;
    for (int k = 1; k < 3; ++k) one = one && piece[s.corners(s.F(f, k), 0)] == p;
    out.on_two += !one;
    faces[p].push_back(f);
    int below = 0, above = 0;
    for (int k = 0; k < 3; ++k) {
      below += s.V(s.F(f, k), 0) < plane_x - 1e-6;
      above += s.V(s.F(f, k), 0) > plane_x + 1e-6;
    }
    out.straddling += below > 0 && above > 0;
  }
  for (Eigen::Index v = 0; v < s.V.rows(); ++v) out.on_cut += std::abs(s.V(v, 0) - plane_x) < 1e-6;
  for (const auto& [p, list] : faces) {
    SurfaceMesh m;
    m.V = s.V;
    m.F.resize(static_cast<Eigen::Index>(list.size()), 3);
    std::map<std::pair<int32_t, int32_t>, int> directed;
    for (size_t r = 0; r < list.size(); ++r) {
      m.F.row(static_cast<Eigen::Index>(r)) = s.F.row(list[r]);
      for (int k = 0; k < 3; ++k) ++directed[{s.F(list[r], k), s.F(list[r], (k + 1) % 3)}];
    }
    for (const auto& [e, n] : directed) {
      const auto twin = directed.find({e.second, e.first});
      out.open_edges += n != 1 || twin == directed.end() || twin->second != 1;
    }
    out.volume[p] = geometry::enclosed_volume(m);
  }
  return out;
}

}  // namespace lamina::test
