// A progressive cut's fine surfaces split along the new part of its path only
// (CutOptions::unsplit_new): of the triangles the surfaces had before the scalpel began, those the
// blade crosses and its new part reaches are split again from their unsplit state; what earlier
// events made of the others is kept. The surfaces' own triangles along the path's earlier part are
// never split again (a split along an already split surface met CGAL's corefinement edge-on), and
// an event no longer splits the whole path so far (the anatomy case's events grew from 13 to
// 117 ms along a 223 mm incision: docs/benchmarks.md).
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <unordered_map>

#include "cut_internal.h"

namespace lamina::model::detail {
namespace {

using Key = std::array<int32_t, 3>;

Key sorted_triangle(const Eigen::MatrixX3i& F, Eigen::Index f) {
  Key k{F(f, 0), F(f, 1), F(f, 2)};
  std::sort(k.begin(), k.end());
  return k;
}

// The unsplit triangles the blade crosses, on a grid of cells about a triangle wide: which one a
// point lies in (its plane, inside it).
struct FaceGrid {
  const EmbeddedSurface& u;
  const std::vector<Eigen::Index>& faces;
  double cell = 1.0;
  Eigen::Vector3d lo = Eigen::Vector3d::Zero();
  std::unordered_map<uint64_t, std::vector<int32_t>> at;

  FaceGrid(const EmbeddedSurface& u_, const std::vector<Eigen::Index>& faces_)
      : u(u_), faces(faces_) {
    if (faces.empty()) return;
    Eigen::AlignedBox3d all;
    double size = 0.0;
    for (const Eigen::Index f : faces) {
      const Eigen::AlignedBox3d b = box(f);
      all.extend(b), size += b.sizes().maxCoeff();
    }
    cell = std::max(size / static_cast<double>(faces.size()), 1e-6);
    lo = all.min();
    for (size_t q = 0; q < faces.size(); ++q) {
      const Eigen::AlignedBox3d b = box(faces[q]);
      const Eigen::Vector3i a = cell_of(b.min()), z = cell_of(b.max());
      for (int i = a.x(); i <= z.x(); ++i)
        for (int j = a.y(); j <= z.y(); ++j)
          for (int k = a.z(); k <= z.z(); ++k) at[key(i, j, k)].push_back(static_cast<int32_t>(q));
    }
  }
  Eigen::AlignedBox3d box(Eigen::Index f) const {
    Eigen::AlignedBox3d b;
    for (int k = 0; k < 3; ++k) b.extend(u.V.row(u.F(f, k)).transpose());
    return Eigen::AlignedBox3d(b.min().array() - 1e-6, b.max().array() + 1e-6);
  }
  Eigen::Vector3i cell_of(const Eigen::Vector3d& p) const {
    return ((p - lo) / cell).array().floor().cast<int>().max(-1000000).min(1000000);
  }
  static uint64_t key(int i, int j, int k) {
    const auto w = [](int v) { return static_cast<uint64_t>(v + (1 << 20)) & 0x1FFFFF; };
    return (w(i) << 42) | (w(j) << 21) | w(k);
  }
  // The position in `faces` of the triangle holding p (in its plane to 1e-6 mm, inside it), the
  // best held of those that do; -1 for none.
  int holding(const Eigen::Vector3d& p) const {
    const Eigen::Vector3i c = cell_of(p);
    const auto it = at.find(key(c.x(), c.y(), c.z()));
    if (it == at.end()) return -1;
    int best = -1;
    double most = -1e-9;
    for (const int32_t q : it->second) {
      const Eigen::Index f = faces[static_cast<size_t>(q)];
      const Eigen::Vector3d a = u.V.row(u.F(f, 0)), b = u.V.row(u.F(f, 1)), d = u.V.row(u.F(f, 2));
      const Eigen::Vector3d e1 = b - a, e2 = d - a, n = e1.cross(e2);
      const double area2 = n.squaredNorm();
      if (!(area2 > 0.0)) continue;
      const Eigen::Vector3d r = p - a;
      if (std::abs(n.dot(r)) > 1e-6 * std::sqrt(area2)) continue;
      // Barycentric coordinates through the normal (no division by small edge products).
      const double v = n.dot(r.cross(e2)) / area2, w = n.dot(e1.cross(r)) / area2;
      const double least = std::min({1.0 - v - w, v, w});
      if (least > most) most = least, best = q;
    }
    return best;
  }
};

}  // namespace

void unsplit_like(const EmbeddedSurface& u, EmbeddedSurface& s) {
  const Eigen::Index n0 = u.V.rows();
  EmbeddedSurface fresh = u;
  fresh.corners = s.corners.topRows(n0);
  fresh.weights = s.weights.topRows(n0);
  fresh.offsets =
      s.offsets.rows() > 0 ? Eigen::MatrixX3d(s.offsets.topRows(n0)) : Eigen::MatrixX3d(0, 3);
  fresh.outside = u.outside;
  s = std::move(fresh);
}

Resplit drop_resplit_part(const EmbeddedSurface& u, const BladeIndex& whole,
                          const BladeIndex& fresh, EmbeddedSurface& s) {
  Resplit r;
  r.unsplit = &u;
  const Eigen::Index n0 = u.V.rows();
  // The unsplit triangles the whole blade crosses; those whose boxes meet a triangle of its new
  // part are split again (the others meet only blade triangles they met at the last split).
  const std::vector<Eigen::Index> crossed = crossed_triangles(u, whole);
  std::vector<uint8_t> again(crossed.size(), 0);
  std::map<Key, size_t> by_corners;
  for (size_t q = 0; q < crossed.size(); ++q) {
    const Eigen::Index f = crossed[q];
    Eigen::Vector3d lo = u.V.row(u.F(f, 0)), hi = lo;
    for (int k = 1; k < 3; ++k) {
      lo = lo.cwiseMin(u.V.row(u.F(f, k)).transpose());
      hi = hi.cwiseMax(u.V.row(u.F(f, k)).transpose());
    }
    lo.array() -= 1e-6, hi.array() += 1e-6;
    if ((hi.array() < fresh.lo.array()).any() || (lo.array() > fresh.hi.array()).any()) continue;
    for (const BladeTriangle& t : fresh.tris)
      if (!((hi.array() < t.lo.array()).any() || (lo.array() > t.hi.array()).any())) {
        again[q] = 1;
        break;
      }
    if (again[q]) by_corners.emplace(sorted_triangle(u.F, f), q);
  }
  for (size_t q = 0; q < crossed.size(); ++q)
    if (again[q]) r.faces.emplace_back(u.F.row(crossed[q]));
  // The seams: edges of a triangle split again shared with a crossed one that is not (the blade
  // crosses such an edge: both its triangles are crossed).
  {
    std::unordered_map<uint64_t, int> seen;  // bit 1: in one split again, bit 2: in one kept
    for (size_t q = 0; q < crossed.size(); ++q)
      for (int k = 0; k < 3; ++k)
        seen[edge_key(u.F(crossed[q], k), u.F(crossed[q], (k + 1) % 3))] |= again[q] ? 1 : 2;
    for (const auto& [e, bits] : seen)
      if (bits == 3)
        r.seams.emplace_back(static_cast<int32_t>(e >> 32), static_cast<int32_t>(e & 0xFFFFFFFFu));
  }
  if (r.faces.empty()) return r;

  // What the earlier events made of them goes: the triangle itself where it was never split, else
  // the triangles inside it (sub-triangles of a crossed triangle lie in it; a section's cap lies
  // in none).
  const FaceGrid grid(u, crossed);
  std::vector<uint8_t> drop(static_cast<size_t>(s.F.rows()), 0);
  std::vector<uint8_t> cap(static_cast<size_t>(s.F.rows()), 0);
  std::unordered_map<int32_t, std::vector<Eigen::Index>> faces_of;  // split-made vertices'
  for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
    const bool made = s.F(f, 0) >= n0 || s.F(f, 1) >= n0 || s.F(f, 2) >= n0;
    if (!made) {
      drop[static_cast<size_t>(f)] = by_corners.count(sorted_triangle(s.F, f)) > 0;
      continue;
    }
    for (int k = 0; k < 3; ++k)
      if (s.F(f, k) >= n0) faces_of[s.F(f, k)].push_back(f);
    const Eigen::Vector3d c =
        (s.V.row(s.F(f, 0)) + s.V.row(s.F(f, 1)) + s.V.row(s.F(f, 2))).transpose() / 3.0;
    const int q = grid.holding(c);
    if (q < 0) {
      cap[static_cast<size_t>(f)] = 1;
    } else {
      drop[static_cast<size_t>(f)] = again[static_cast<size_t>(q)];
    }
  }
  // A split-made vertex no kept triangle but caps uses goes, and every cap joined to it (a
  // section's cap is made again where its loop is).
  std::vector<uint8_t> gone(static_cast<size_t>(s.V.rows()), 0);
  std::vector<int32_t> check;
  for (Eigen::Index f = 0; f < s.F.rows(); ++f)
    if (drop[static_cast<size_t>(f)])
      for (int k = 0; k < 3; ++k)
        if (s.F(f, k) >= n0) check.push_back(s.F(f, k));
  while (!check.empty()) {
    const int32_t v = check.back();
    check.pop_back();
    if (gone[static_cast<size_t>(v)]) continue;
    bool held = false;
    for (const Eigen::Index f : faces_of[v])
      held = held || (!drop[static_cast<size_t>(f)] && !cap[static_cast<size_t>(f)]);
    if (held) continue;
    gone[static_cast<size_t>(v)] = 1;
    for (const Eigen::Index f : faces_of[v]) {
      if (drop[static_cast<size_t>(f)]) continue;
      drop[static_cast<size_t>(f)] = 1;  // a cap
      for (int k = 0; k < 3; ++k)
        if (s.F(f, k) >= n0 && !gone[static_cast<size_t>(s.F(f, k))]) check.push_back(s.F(f, k));
    }
  }
  // The vertices left, the triangles left renumbered.
  std::vector<uint8_t> stays(gone.size());
  for (size_t v = 0; v < gone.size(); ++v) stays[v] = !gone[v];
  const std::vector<int32_t> to = keep_vertices(s, n0, stays);
  Eigen::Index kept = 0;
  for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
    if (drop[static_cast<size_t>(f)]) continue;
    Eigen::RowVector3i g;
    for (int k = 0; k < 3; ++k) g[k] = to[static_cast<size_t>(s.F(f, k))];
    if (g.minCoeff() < 0) continue;  // (a triangle on a gone vertex: a cap, above)
    s.F.row(kept++) = g;
  }
  s.F.conservativeResize(kept, 3);
  // Outside the tetrahedra: the unsplit surface's and the split-made ones still here.
  s.outside = u.outside;
  for (Eigen::Index v = n0; v < s.V.rows(); ++v) s.outside += s.weights.row(v).minCoeff() < 0.0;
  return r;
}

}  // namespace lamina::model::detail
