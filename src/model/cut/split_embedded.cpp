// The fine surfaces cut exactly: the display skin and each embedded structure split along the
// blade's surface at rest (geometry::split_surface, CGAL's corefinement) where the tetrahedra
// open, each new vertex embedded in the tetrahedron holding it and told its side by a point on
// its own triangles (once the vertices follow their copies, close_sections.cpp caps what the cut
// closed off).
#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <exception>
#include <functional>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <unordered_map>

#include "cut_internal.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/geometry/split_surface.h"

namespace lamina::model::detail {
namespace {

// Row r's four corners sorted: a tetrahedron's key whatever order its corners are listed in.
template <class Rows>
std::array<int32_t, 4> sorted_corners(const Rows& C, Eigen::Index r) {
  std::array<int32_t, 4> c{C(r, 0), C(r, 1), C(r, 2), C(r, 3)};
  std::sort(c.begin(), c.end());
  return c;
}

// The tetrahedra around the cut at rest, for locating points among them.
struct Locator {
  const Eigen::MatrixX3d& X;
  const Eigen::MatrixX4i& T;
  std::vector<int32_t> tets;
  std::vector<Eigen::Matrix3d> inverse;
  std::vector<Eigen::AlignedBox3d> box;  // each one's, grown by the margin
  double reach = 0.0;                    // how far from the blade a vertex may follow one across

  // Over `star`, each box grown by `margin` (<= 0: half the tetrahedra's mean edge, about how
  // far a display skin lies off the tetrahedra's surface).
  Locator(const Eigen::MatrixX3d& X_, const Eigen::MatrixX4i& T_, const std::vector<int32_t>& star,
          double margin = 0.0)
      : X(X_), T(T_) {
    if (!(margin > 0.0)) {
      double edge = 0.0;
      for (const int32_t t : star) edge += (X.row(T(t, 1)) - X.row(T(t, 0))).norm();
      margin = star.empty() ? 0.0 : 0.5 * edge / static_cast<double>(star.size());
    }
    reach = 4.0 * margin;
    for (const int32_t t : star) {
      Eigen::Matrix3d D;
      for (int k = 1; k < 4; ++k) D.col(k - 1) = (X.row(T(t, k)) - X.row(T(t, 0))).transpose();
      const Eigen::FullPivLU<Eigen::Matrix3d> lu(D);
      if (!lu.isInvertible()) continue;
      const Eigen::AlignedBox3d b = tet_box(X, T, t);
      tets.push_back(t), inverse.push_back(lu.inverse());
      box.emplace_back(b.min().array() - margin, b.max().array() + margin);
    }
    // A uniform grid of the boxes, cells about a box wide: a point's box candidates are those
    // of its cell (a query scanned every box: 30% of a paper-size cut in perf).
    if (box.empty()) return;
    Eigen::AlignedBox3d all;
    double size = 0.0;
    for (const Eigen::AlignedBox3d& b : box) all.extend(b), size += b.sizes().maxCoeff();
    cell = std::max(size / static_cast<double>(box.size()), 1e-9);
    lo = all.min();
    for (size_t c = 0; c < box.size(); ++c) {
      const Eigen::Vector3i a = cell_of(box[c].min()), z = cell_of(box[c].max());
      for (int i = a.x(); i <= z.x(); ++i)
        for (int j = a.y(); j <= z.y(); ++j)
          for (int k = a.z(); k <= z.z(); ++k)
            grid[key(i, j, k)].push_back(static_cast<int32_t>(c));
    }
  }

  double cell = 1.0;
  Eigen::Vector3d lo = Eigen::Vector3d::Zero();
  std::unordered_map<uint64_t, std::vector<int32_t>> grid;
  Eigen::Vector3i cell_of(const Eigen::Vector3d& p) const {
    return ((p - lo) / cell).array().floor().cast<int>().max(-1000000).min(1000000);
  }
  static uint64_t key(int i, int j, int k) {
    const auto u = [](int v) { return static_cast<uint64_t>(v + (1 << 20)) & 0x1FFFFF; };
    return (u(i) << 42) | (u(j) << 21) | u(k);
  }

  Eigen::Vector4d bary(size_t c, const Eigen::Vector3d& p) const {
    const Eigen::Vector3d l = inverse[c] * (p - X.row(T(tets[c], 0)).transpose());
    return {1.0 - l.sum(), l[0], l[1], l[2]};
  }

  // The tetrahedron (index into tets) holding p, or the one it is least outside of, among those
  // `allowed` says; -1 when p is beyond every one's margin.
  template <class Allowed>
  int locate(const Eigen::Vector3d& p, const Allowed& allowed, bool within_margin = true) const {
    int best = -1;
    double score = -std::numeric_limits<double>::infinity();
    // The filter (a tetrahedron's side of the blade, its material's centre) only for one that
    // would be the best so far: the same choice, and a scan of every tetrahedron (a structure's
    // vertex far outside the organ) no longer filters each (30 of a 75 ms cut event with three
    // structures).
    const auto consider = [&](size_t c) {
      const double s = bary(c, p).minCoeff();
      if (s > score && allowed(tets[c])) score = s, best = static_cast<int>(c);
      return score >= 0.0;  // inside
    };
    if (!within_margin) {
      for (size_t c = 0; c < tets.size(); ++c)
        if (consider(c)) break;
      return best;
    }
    const Eigen::Vector3i at = cell_of(p);
    const auto it = grid.find(key(at.x(), at.y(), at.z()));
    if (it == grid.end()) return -1;
    for (const int32_t c : it->second)
      if (box[static_cast<size_t>(c)].contains(p) && consider(static_cast<size_t>(c))) break;
    return best;
  }
};

// The blade without its degenerate triangles (CGAL's corefinement wants none).
SurfaceMesh splitter_of(const Blade& blade) {
  SurfaceMesh s;
  s.V = blade.V;
  std::vector<Eigen::RowVector3i> keep;
  for (Eigen::Index f = 0; f < blade.F.rows(); ++f) {
    const Eigen::Vector3d a = blade.V.row(blade.F(f, 0)), b = blade.V.row(blade.F(f, 1)),
                          c = blade.V.row(blade.F(f, 2));
    if ((b - a).cross(c - a).norm() > 0.0) keep.push_back(blade.F.row(f));
  }
  s.F.resize(static_cast<Eigen::Index>(keep.size()), 3);
  for (size_t f = 0; f < keep.size(); ++f) s.F.row(static_cast<Eigen::Index>(f)) = keep[f];
  return s;
}

// The triangles of `index` whose boxes meet `box`.
BladeIndex blade_within(const BladeIndex& index, const Eigen::AlignedBox3d& box) {
  BladeIndex out;
  out.eps = index.eps;
  Eigen::AlignedBox3d all;
  for (const BladeTriangle& t : index.tris)
    if (!((t.hi.array() < box.min().array()).any() || (t.lo.array() > box.max().array()).any())) {
      out.tris.push_back(t);
      all.extend(t.lo), all.extend(t.hi);
    }
  if (!out.tris.empty()) out.lo = all.min(), out.hi = all.max();
  return out;
}

// Splits one surface; returns per vertex a point on its side for those on the cut (NaN for the
// others).
// Which side of the blade points near it are on: the blade triangle over p (its projection on
// the triangle's plane inside it), the nearest such; -1 when none is.
}  // namespace

int blade_triangle_at(const BladeIndex& index, const Eigen::Vector3d& p, double reach) {
  int best = -1;
  double nearest = reach;
  for (size_t k = 0; k < index.tris.size(); ++k) {
    const BladeTriangle& t = index.tris[k];
    if ((p.array() < t.lo.array() - reach).any() || (p.array() > t.hi.array() + reach).any())
      continue;
    const Eigen::Vector3d q = p - t.p0;
    const double d = std::abs(t.n.dot(q));
    if (d > nearest) continue;
    if (in_triangle(t, q, 1e-6)) nearest = d, best = static_cast<int>(k);
  }
  return best;
}

// The tetrahedra a point on one side of the blade may follow: a divided one (its copy on the
// point's side then carries it) or a whole one on the same side (its centroid, against the
// blade triangle over the point). A display skin vertex outside the tetrahedra that follows
// the nearest one would otherwise follow one across the cut.
// Where a tetrahedron's material is: the centroid of the corners it carries (all four for a whole
// one; an earlier cut's copy carries those on its side).
Eigen::Vector3d material_centre(const Eigen::MatrixX3d& X, const Eigen::MatrixX4i& T,
                                const Tets& tets, int32_t t) {
  const uint8_t mask = tets.material_of(t);
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  int n = 0;
  for (int k = 0; k < 4; ++k)
    if (mask >> k & 1) c += X.row(T(t, k)).transpose(), ++n;
  return n > 0 ? Eigen::Vector3d(c / n) : c;
}

namespace {

struct SideFilter {
  const Locator& where;
  const Tets& tets;
  const std::vector<uint8_t>& divided;  // per tetrahedron of T
  const BladeTriangle* tri = nullptr;   // none: any tetrahedron
  bool above = false;
  bool operator()(int32_t t) const {
    if (!tri || divided[static_cast<size_t>(t)]) return true;
    const Eigen::Vector3d c = material_centre(where.X, where.T, tets, t);
    return (tri->n.dot(c - tri->p0) > 0.0) == above;
  }
};

// Vertex i of s embedded at p in the located tetrahedron where.tets[c] (an offset when the
// weights would amplify more than kMaxAmplification).
void embed_at(const Locator& where, int c, const Eigen::Vector3d& p, EmbeddedSurface& s,
              Eigen::Index i) {
  const int32_t t = where.tets[static_cast<size_t>(c)];
  Eigen::Vector4d w = where.bary(static_cast<size_t>(c), p);
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  if (w.cwiseAbs().sum() > kMaxAmplification) {  // far outside: the nearest corner mix, offset
    w = w.cwiseMax(0.0);
    w /= w.sum();
    Eigen::Vector3d q = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) q += w[k] * where.X.row(where.T(t, k)).transpose();
    offset = p - q;
  }
  if (!offset.isZero() && s.offsets.rows() == 0) s.offsets = Eigen::MatrixX3d::Zero(s.V.rows(), 3);
  if (s.offsets.rows() > 0) s.offsets.row(i) = offset.transpose();
  s.corners.row(i) = where.T.row(t);
  s.weights.row(i) = w.transpose();
}

// Vertices near the blade that follow a whole tetrahedron across it (outside the tetrahedra, the
// one they were least outside of) follow one on their side instead.
// The tetrahedra around the cut by their corners (a vertex further away is not near it).
using Around = std::map<std::array<int32_t, 4>, int32_t>;

// `near`: per node, whether it is a corner of a tetrahedron this cut divides (a vertex in a
// tetrahedron around the cut has one: asked before the map).
bool has_near_corner(const std::vector<uint8_t>& near, const EmbeddedSurface& s, Eigen::Index v) {
  return near[s.corners(v, 0)] || near[s.corners(v, 1)] || near[s.corners(v, 2)] ||
         near[s.corners(v, 3)];
}

void keep_sides(const Locator& where, const Around& around, const Tets& tets,
                const std::vector<uint8_t>& divided, const std::vector<uint8_t>& near,
                const BladeIndex& index, double reach, EmbeddedSurface& s) {
  for (Eigen::Index v = 0; v < s.V.rows(); ++v) {
    if (!has_near_corner(near, s, v)) continue;
    const Eigen::Vector3d p = s.V.row(v).transpose();
    if ((p.array() < index.lo.array() - reach).any() ||
        (p.array() > index.hi.array() + reach).any())
      continue;
    // Only a vertex in a whole tetrahedron around the cut is looked at: asked first, since
    // the blade's triangles over it are searched among all of a progressive cut's, which grow
    // with the incision, for every vertex in the blade's box (most of a display skin).
    const std::array<int32_t, 4> own = sorted_corners(s.corners, v);
    const auto it = around.find(own);
    if (it == around.end() || divided[static_cast<size_t>(it->second)]) continue;
    const int k = blade_triangle_at(index, p, reach);
    if (k < 0) continue;
    const BladeTriangle& tri = index.tris[static_cast<size_t>(k)];
    const double d = tri.n.dot(p - tri.p0);
    if (std::abs(d) <= 1e-7) continue;  // on the blade: take_apart()'s
    const Eigen::Vector3d c = material_centre(where.X, where.T, tets, it->second);
    if ((tri.n.dot(c - tri.p0) > 0.0) == (d > 0.0)) continue;  // its own side
    const SideFilter allowed{where, tets, divided, &tri, d > 0.0};
    // Only into one that holds it about as well (no vertex moved onto an offset).
    const int at = where.locate(p, allowed);
    if (at >= 0 && where.bary(static_cast<size_t>(at), p).cwiseAbs().sum() <= kMaxAmplification)
      embed_at(where, at, p, s, v);
  }
}

// The blade triangle the segment from p to q crosses (strictly between them), or -1.
int blade_crossed(const BladeIndex& index, const Eigen::Vector3d& p, const Eigen::Vector3d& q) {
  const Eigen::Vector3d lo = p.cwiseMin(q), hi = p.cwiseMax(q);
  if ((hi.array() < index.lo.array()).any() || (lo.array() > index.hi.array()).any()) return -1;
  for (size_t k = 0; k < index.tris.size(); ++k) {
    const BladeTriangle& t = index.tris[k];
    if ((hi.array() < t.lo.array()).any() || (lo.array() > t.hi.array()).any()) continue;
    const double dp = t.n.dot(p - t.p0), dq = t.n.dot(q - t.p0);
    if (!(dp * dq < 0.0)) continue;
    if (in_triangle(t, p + (dp / (dp - dq)) * (q - p) - t.p0, 0.0)) return static_cast<int>(k);
  }
  return -1;
}

// Vertices outside the tetrahedra farther from the blade than keep_sides() looks (a structure
// beside the organ, TotalSegmentator's vena cava and gallbladder, follows the nearest ones)
// whose whole tetrahedron's material lies across the blade from them: they follow the nearest
// tetrahedron near the blade on their own side instead. Else a vessel beside a liver cut
// through tore between the two pieces, some of its vertices following the other one.
// `copies`: every earlier cut's copy of a tetrahedron by its corners (a vertex such a search
// put in a divided tetrahedron follows the copy on its side, whose corners' mean is the whole
// tetrahedron's, across the blade: it was searched again at every later event of the same
// incision, 1,736 vertices of a gallbladder beside a liver, a third of an event's time).
void keep_far_sides(const Around& around, const Around& copies, const Tets& tets,
                    const std::vector<uint8_t>& divided, const BladeIndex& index,
                    const std::function<const Locator&()>& wide, const Eigen::MatrixX3d& X,
                    const Eigen::MatrixX4i& T, EmbeddedSurface& s) {
  std::vector<std::pair<Eigen::Index, int>> across;  // a vertex and the blade triangle between
  for (Eigen::Index v = 0; v < s.V.rows(); ++v) {
    // Inside its own tetrahedron: on its side. (Far outside, weights clamped and an offset.)
    const bool offset = s.offsets.rows() > 0 && !s.offsets.row(v).isZero();
    if (s.weights.row(v).minCoeff() >= 0.0 && !offset) continue;
    // The segment to its tetrahedron's material lies in the box of the point and the corners:
    // one that misses the blade's box crosses no blade triangle (most of a display skin's
    // vertices, outside the tetrahedra by the skin's chords, are far from the blade: their
    // lookups were 10% of a paper-size cut event).
    const Eigen::Vector3d p = s.V.row(v).transpose();
    Eigen::AlignedBox3d reach(p);
    for (int k = 0; k < 4; ++k) reach.extend(X.row(s.corners(v, k)).transpose());
    if ((reach.max().array() < index.lo.array()).any() ||
        (reach.min().array() > index.hi.array()).any())
      continue;
    const std::array<int32_t, 4> own = sorted_corners(s.corners, v);
    const auto it = around.find(own);
    if (it != around.end() && divided[static_cast<size_t>(it->second)]) continue;
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    const auto copy = it == around.end() ? copies.find(own) : copies.end();
    if (it != around.end()) {
      c = material_centre(X, T, tets, it->second);
    } else if (copy != copies.end()) {
      c = material_centre(X, T, tets, copy->second);
    } else {
      for (int k = 0; k < 4; ++k) c += X.row(s.corners(v, k)).transpose() / 4.0;
    }
    const int k = blade_crossed(index, p, c);
    // (A vertex on the blade, an earlier event's split made, is told its side by its triangles
    // in take_apart(): its side of the blade here is rounding's.)
    if (k >= 0 && std::abs(index.tris[static_cast<size_t>(k)].n.dot(
                      p - index.tris[static_cast<size_t>(k)].p0)) > 1e-7)
      across.emplace_back(v, k);
  }
  if (across.empty()) return;
  // Each one's search scans every tetrahedron near the blade: on the threads (read only), the
  // vertices then embedded in order.
  const Locator& near = wide();
  std::vector<int> at(across.size(), -1);
#pragma omp parallel for schedule(dynamic, 8)
  for (size_t q = 0; q < across.size(); ++q) {
    const Eigen::Vector3d p = s.V.row(across[q].first).transpose();
    const BladeTriangle& tri = index.tris[static_cast<size_t>(across[q].second)];
    const SideFilter allowed{near, tets, divided, &tri, tri.n.dot(p - tri.p0) > 0.0};
    at[q] = near.locate(p, allowed, /*within_margin=*/false);
  }
  for (size_t q = 0; q < across.size(); ++q)
    if (at[q] >= 0) embed_at(near, at[q], s.V.row(across[q].first).transpose(), s, across[q].first);
}

// Vertices an earlier split left on the blade (a progressive cut sweeps its path again) are told
// their side by their triangles': where their tetrahedron opens now, a welded one (where the
// tissue had not opened yet: the cut's tip) is taken apart, keeping the triangles on one side, a
// copy of it (appended) taking the others. Returns points on their sides.
// Only a vertex with a corner of a divided tetrahedron (`near`) is looked at: the others follow
// their tetrahedra's nodes, renumbered (cut_tetrahedra's relocation asks no side of them), and
// a progressive cut's earlier events left thousands on the blade along its path.
std::vector<std::pair<int32_t, Eigen::Vector3d>> take_apart(
    const std::set<std::array<int32_t, 4>>& divided, const std::vector<uint8_t>& near,
    const BladeIndex& index, EmbeddedSurface& s) {
  std::vector<std::pair<int32_t, Eigen::Vector3d>> hints;
  constexpr double kOn = 1e-7;  // mm: a vertex a split made lies on the blade to rounding
  std::unordered_map<int32_t, Eigen::Vector3d> normal;  // the blade's there
  for (Eigen::Index v = 0; v < s.V.rows(); ++v) {
    if (!has_near_corner(near, s, v)) continue;
    const Eigen::Vector3d p = s.V.row(v).transpose();
    if ((p.array() < index.lo.array() - kOn).any() || (p.array() > index.hi.array() + kOn).any())
      continue;
    for (const BladeTriangle& t : index.tris) {
      if ((p.array() < t.lo.array() - kOn).any() || (p.array() > t.hi.array() + kOn).any())
        continue;
      const Eigen::Vector3d q = p - t.p0;
      if (std::abs(t.n.dot(q)) > kOn) continue;
      normal.emplace(static_cast<int32_t>(v), t.n);
      break;
    }
  }
  if (normal.empty()) return hints;
  // Their triangles (a flag per vertex: a hash lookup per corner of a 100,000-triangle display
  // skin was 2 ms of a cut event).
  std::vector<uint8_t> on(static_cast<size_t>(s.V.rows()), 0);
  for (const auto& [v, n] : normal) on[static_cast<size_t>(v)] = 1;
  std::unordered_map<int32_t, std::vector<Eigen::Index>> faces;
  for (Eigen::Index f = 0; f < s.F.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (on[static_cast<size_t>(s.F(f, k))]) faces[s.F(f, k)].push_back(f);
  for (const auto& [v, n] : normal) {
    const Eigen::Vector3d p = s.V.row(v).transpose();
    std::vector<Eigen::Index> below;
    Eigen::Vector3d above_point, below_point;
    bool above = false;
    for (const Eigen::Index f : faces[v]) {
      const Eigen::Vector3d c =
          (s.V.row(s.F(f, 0)) + s.V.row(s.F(f, 1)) + s.V.row(s.F(f, 2))).transpose() / 3.0;
      double d = n.dot(c - p);
      if (std::abs(d) <= kOn) {
        // A section's cap, on the blade: it closes the side it faces away from.
        const Eigen::Vector3d a = s.V.row(s.F(f, 0)), b = s.V.row(s.F(f, 1)),
                              e = s.V.row(s.F(f, 2));
        // (Facing along n, it is the below side's; no side point from it: it is on the blade.)
        if (n.dot((b - a).cross(e - a)) > 0.0) below.push_back(f);
        continue;
      }
      if (d < -kOn) below.push_back(f), below_point = c;
      if (d > kOn) above = true, above_point = c;
    }
    // On one side only (a vertex of a seam that was not welded): only told its side. A welded
    // vertex is taken apart only where its tetrahedron opens now.
    const std::array<int32_t, 4> own = sorted_corners(s.corners, v);
    if (below.empty() || !above || !divided.count(own)) {
      if (above) {
        hints.emplace_back(v, above_point);
      } else if (!below.empty()) {
        hints.emplace_back(v, below_point);
      }
      continue;
    }
    const Eigen::Index copy = s.V.rows();
    s.V.conservativeResize(copy + 1, 3), s.V.row(copy) = s.V.row(v);
    s.corners.conservativeResize(copy + 1, 4), s.corners.row(copy) = s.corners.row(v);
    s.weights.conservativeResize(copy + 1, 4), s.weights.row(copy) = s.weights.row(v);
    if (s.offsets.rows() > 0)
      s.offsets.conservativeResize(copy + 1, 3), s.offsets.row(copy) = s.offsets.row(v);
    for (const Eigen::Index f : below)
      for (int k = 0; k < 3; ++k)
        if (s.F(f, k) == v) s.F(f, k) = static_cast<int32_t>(copy);
    hints.emplace_back(v, above_point);
    hints.emplace_back(static_cast<int32_t>(copy), below_point);
  }
  return hints;
}

}  // namespace

std::vector<Eigen::Index> crossed_triangles(const EmbeddedSurface& s, const BladeIndex& index,
                                            bool first) {
  std::vector<double> hits;
  std::unordered_map<uint64_t, bool> crossed_edge;
  auto crossed = [&](int32_t a, int32_t b) {
    const auto [it, fresh] = crossed_edge.try_emplace(edge_key(a, b), false);
    if (!fresh) return it->second;
    const Eigen::Vector3d pa = s.V.row(std::min(a, b)), pb = s.V.row(std::max(a, b));
    edge_hits(pa, pb, index, hits);
    for (const double f : hits) it->second = it->second || (f > 1e-9 && f < 1.0 - 1e-9);
    return it->second;
  };
  std::vector<Eigen::Index> patch;
  for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
    Eigen::Vector3d lo = s.V.row(s.F(f, 0)), hi = lo;
    for (int k = 1; k < 3; ++k) {
      lo = lo.cwiseMin(s.V.row(s.F(f, k)).transpose());
      hi = hi.cwiseMax(s.V.row(s.F(f, k)).transpose());
    }
    if ((hi.array() < index.lo.array()).any() || (lo.array() > index.hi.array()).any()) continue;
    bool any = false;
    for (int k = 0; k < 3; ++k) any = crossed(s.F(f, k), s.F(f, (k + 1) % 3)) || any;
    if (any) patch.push_back(f);
    if (any && first) break;
  }
  return patch;
}

namespace {

// Which side of the blade at q the triangles `faces` of (V, F) are on: +1, -1, 0 (both or none).
int side_at(const BladeIndex& index, const Eigen::Vector3d& q, const Eigen::MatrixX3d& V,
            const Eigen::MatrixX3i& F, const std::vector<Eigen::Index>& faces) {
  const int k = blade_triangle_at(index, q, 1e-6);
  if (k < 0) return 0;
  const Eigen::Vector3d n = index.tris[static_cast<size_t>(k)].n;
  bool above = false, below = false;
  for (const Eigen::Index f : faces) {
    const Eigen::Vector3d c = (V.row(F(f, 0)) + V.row(F(f, 1)) + V.row(F(f, 2))).transpose() / 3.0;
    const double d = n.dot(c - q);
    above = above || d > 1e-9, below = below || d < -1e-9;
  }
  return above == below ? 0 : (above ? 1 : -1);
}

// A split along the path's new part only (Resplit): its new vertices where the blade crosses a
// seam are the surface's own there (what an earlier event made of the triangle across it), by
// position and side (a vertex welded where the tissue had not opened serves both). False when
// one is not found.
bool match_seams(const Resplit& again, const geometry::SplitSurface& cut, const BladeIndex& index,
                 const EmbeddedSurface& s, std::vector<int32_t>& matched) {
  constexpr double kSame = 1e-6;  // mm: the same crossing, computed twice
  std::vector<Eigen::Vector3d> points;
  std::vector<double> hits;
  for (const auto& [a, b] : again.seams) {
    const Eigen::Vector3d pa = s.V.row(std::min(a, b)), pb = s.V.row(std::max(a, b));
    edge_hits(pa, pb, index, hits);
    for (const double f : hits)
      if (f > 1e-9 && f < 1.0 - 1e-9) points.push_back(pa + f * (pb - pa));
  }
  if (points.empty()) return true;
  const auto near = [&](const Eigen::Vector3d& p) {
    for (size_t q = 0; q < points.size(); ++q)
      if ((p - points[q]).squaredNorm() <= kSame * kSame) return static_cast<int>(q);
    return -1;
  };
  // Each crossing's vertices in the split and in the surface, with their triangles.
  const Eigen::Index n0 = again.unsplit->V.rows();
  std::map<int32_t, std::vector<Eigen::Index>> cut_faces, own_faces;
  std::vector<int> cut_at(cut.origin.size(), -1);
  for (size_t v = 0; v < cut.origin.size(); ++v)
    if (cut.origin[v] < 0) cut_at[v] = near(cut.V.row(static_cast<Eigen::Index>(v)).transpose());
  std::unordered_map<int32_t, int> own_at;
  for (Eigen::Index v = n0; v < s.V.rows(); ++v) {
    const int q = near(s.V.row(v).transpose());
    if (q >= 0) own_at.emplace(static_cast<int32_t>(v), q);
  }
  for (Eigen::Index f = 0; f < cut.F.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (cut_at[static_cast<size_t>(cut.F(f, k))] >= 0) cut_faces[cut.F(f, k)].push_back(f);
  if (cut_faces.empty()) return true;
  for (Eigen::Index f = 0; f < s.F.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (s.F(f, k) >= n0 && own_at.count(s.F(f, k))) own_faces[s.F(f, k)].push_back(f);
  for (const auto& [v, faces] : cut_faces) {
    const int q = cut_at[static_cast<size_t>(v)];
    const int side = side_at(index, points[static_cast<size_t>(q)], cut.V, cut.F, faces);
    int32_t best = -1;
    for (const auto& [w, wq] : own_at) {
      if (wq != q || !own_faces.count(w)) continue;
      const int own = side_at(index, points[static_cast<size_t>(q)], s.V, s.F, own_faces[w]);
      if (own == side) {
        best = w;
        break;
      }
      if (own == 0 || side == 0) best = w;
    }
    if (best < 0) return false;
    matched[static_cast<size_t>(v)] = best;
  }
  return true;
}

std::vector<Eigen::Vector3d> split_one(
    const Locator& where, const Around& around, const Around& copies, const Tets& tets,
    const std::set<std::array<int32_t, 4>>& divided, const std::vector<uint8_t>& is_divided,
    const std::vector<uint8_t>& near, const BladeIndex& index, const SurfaceMesh& splitter,
    const std::function<const Locator&()>& wide, EmbeddedSurface& s, const Resplit* again,
    bool& seams_found) {
  seams_found = true;
  const double reach = where.reach;
  // The blade's triangles near the vertices with a corner around the cut (within the reach the
  // side checks look): a progressive cut's blade grows with its path, those vertices do not.
  BladeIndex nearby;
  {
    Eigen::AlignedBox3d box;
    for (Eigen::Index v = 0; v < s.V.rows(); ++v)
      if (has_near_corner(near, s, v)) box.extend(s.V.row(v).transpose());
    if (!box.isEmpty()) {
      box = Eigen::AlignedBox3d(box.min().array() - reach, box.max().array() + reach);
      nearby = blade_within(index, box);
    }
  }
  const auto apart = take_apart(divided, near, nearby, s);
  keep_sides(where, around, tets, is_divided, near, nearby, reach, s);
  keep_far_sides(around, copies, tets, is_divided, again && again->fresh ? *again->fresh : index,
                 wide, where.X, where.T, s);
  const Eigen::Index nv = s.V.rows();
  std::vector<Eigen::Vector3d> hint;
  auto with_apart = [&]() {
    if (apart.empty()) return;
    hint.resize(static_cast<size_t>(s.V.rows()), Eigen::Vector3d::Constant(std::nan("")));
    for (const auto& [v, h] : apart) hint[static_cast<size_t>(v)] = h;
  };
  // The triangles with an edge the blade crosses strictly inside. (Where the tissue does not
  // open after all, at the blade's edge, the two sides' vertices are welded again afterwards.)
  // (Along the path's new part only: the unsplit triangles there, the earlier ones' split kept.)
  const std::vector<Eigen::Index> patch =
      again ? std::vector<Eigen::Index>{} : crossed_triangles(s, index);
  std::vector<Eigen::RowVector3i> tris;
  if (again) {
    tris = again->faces;
  } else {
    for (const Eigen::Index f : patch) tris.emplace_back(s.F.row(f));
  }
  if (tris.empty()) {
    with_apart();
    return hint;
  }

  // The patch on its own, split.
  std::unordered_map<int32_t, int32_t> local;
  std::vector<int32_t> global;
  SurfaceMesh part;
  part.F.resize(static_cast<Eigen::Index>(tris.size()), 3);
  for (size_t r = 0; r < tris.size(); ++r)
    for (int k = 0; k < 3; ++k) {
      const int32_t v = tris[r][k];
      const auto [it, fresh] = local.try_emplace(v, static_cast<int32_t>(global.size()));
      if (fresh) global.push_back(v);
      part.F(static_cast<Eigen::Index>(r), k) = it->second;
    }
  part.V.resize(static_cast<Eigen::Index>(global.size()), 3);
  for (size_t k = 0; k < global.size(); ++k)
    part.V.row(static_cast<Eigen::Index>(k)) = s.V.row(global[k]);
  geometry::SplitSurface cut;
  try {
    cut = geometry::split_surface(part, splitter);
  } catch (const Error& e) {
    // (A blade that crosses itself, say.) The cut goes on; this surface keeps its triangles,
    // each vertex following its side's copy, and stretches across the opening: said.
    log::warn("cut: {} not split along the blade ({}); it stretches across the cut there", s.name,
              e.what());
    with_apart();
    return hint;
  }

  // The seams' vertices are the surface's own.
  std::vector<int32_t> matched(cut.origin.size(), -1);
  if (again && !match_seams(*again, cut, index, s, matched)) {
    seams_found = false;
    return hint;
  }
  // New vertices appended, each embedded where it is and given a point on its side: the
  // centroid of a triangle of its own.
  std::vector<int32_t> id(cut.origin.size());
  int32_t added = 0;
  for (size_t v = 0; v < cut.origin.size(); ++v)
    id[v] = cut.origin[v] >= 0 ? global[static_cast<size_t>(cut.origin[v])]
            : matched[v] >= 0  ? matched[v]
                               : static_cast<int32_t>(nv) + added++;
  std::vector<Eigen::Vector3d> side_point(cut.origin.size(), Eigen::Vector3d::Zero());
  for (Eigen::Index f = 0; f < cut.F.rows(); ++f) {
    const Eigen::Vector3d c =
        (cut.V.row(cut.F(f, 0)) + cut.V.row(cut.F(f, 1)) + cut.V.row(cut.F(f, 2))).transpose() /
        3.0;
    for (int k = 0; k < 3; ++k) side_point[cut.F(f, k)] = c;
  }
  const Eigen::Index total = nv + added;
  s.V.conservativeResize(total, 3);
  s.corners.conservativeResize(total, 4);
  s.weights.conservativeResize(total, 4);
  if (s.offsets.rows() > 0) s.offsets.conservativeResize(total, 3);
  if (s.offsets.rows() > 0) s.offsets.bottomRows(added).setZero();
  hint.assign(static_cast<size_t>(total), Eigen::Vector3d::Constant(std::nan("")));
  // Each new vertex's tetrahedron, found on the threads (read only: the searches of a
  // structure's vertices outside the organ scan every tetrahedron near the blade), then embedded
  // in order.
  std::vector<size_t> fresh;  // the split's new vertices
  for (size_t v = 0; v < cut.origin.size(); ++v)
    if (cut.origin[v] < 0 && matched[v] < 0) fresh.push_back(v);
  std::vector<SideFilter> side(fresh.size(), SideFilter{where, tets, is_divided});
  std::vector<int> found(fresh.size(), -1);
  const auto point = [&](size_t q) -> Eigen::Vector3d {
    return cut.V.row(static_cast<Eigen::Index>(fresh[q])).transpose();
  };
#pragma omp parallel for schedule(dynamic, 16)
  for (size_t q = 0; q < fresh.size(); ++q) {
    // Among the tetrahedra its triangles' side may follow.
    const int k = blade_triangle_at(index, point(q), reach);
    if (k >= 0) {
      side[q].tri = &index.tris[static_cast<size_t>(k)];
      side[q].above = side[q].tri->n.dot(side_point[fresh[q]] - side[q].tri->p0) > 0.0;
    }
    found[q] = where.locate(point(q), side[q]);
  }
  // Beyond the tetrahedra around this cut (ahead of a progressive cut's tip, where the tissue
  // has not opened yet: welded again, taken apart when it opens), among all near the blade.
  const bool beyond = std::find(found.begin(), found.end(), -1) != found.end();
  const Locator* wide_in = beyond ? &wide() : nullptr;
  std::vector<int> found_wide(fresh.size(), -1);
  if (beyond) {
#pragma omp parallel for schedule(dynamic, 4)
    for (size_t q = 0; q < fresh.size(); ++q) {
      if (found[q] >= 0) continue;
      const SideFilter in_wide{*wide_in, tets, is_divided, side[q].tri, side[q].above};
      found_wide[q] = wide_in->locate(point(q), in_wide);
      if (found_wide[q] < 0) found_wide[q] = wide_in->locate(point(q), in_wide, false);
    }
  }
  for (size_t q = 0; q < fresh.size(); ++q) {
    const size_t v = fresh[q];
    const int32_t i = id[v];
    const Eigen::Vector3d p = point(q);
    const Locator* in = found[q] >= 0 ? &where : wide_in;
    const int c = found[q] >= 0 ? found[q] : found_wide[q];
    if (c < 0)
      throw Error(ErrorKind::kInternal, "cut: " + s.name + ": a split vertex is in no tetrahedron");
    s.V.row(i) = p.transpose();
    embed_at(*in, c, p, s, i);
    Eigen::Vector4d w = s.weights.row(i).transpose();
    if (w.minCoeff() < 0.0) ++s.outside;
    hint[static_cast<size_t>(i)] = side_point[v];
  }

  // The triangles: the patch's replaced by the split ones (along the new part only, the patch's
  // are gone already).
  std::vector<uint8_t> in_patch(static_cast<size_t>(s.F.rows()), 0);
  for (const Eigen::Index f : patch) in_patch[static_cast<size_t>(f)] = 1;
  Eigen::MatrixX3i F(s.F.rows() - static_cast<Eigen::Index>(patch.size()) + cut.F.rows(), 3);
  Eigen::Index r = 0;
  for (Eigen::Index f = 0; f < s.F.rows(); ++f)
    if (!in_patch[static_cast<size_t>(f)]) F.row(r++) = s.F.row(f);
  for (Eigen::Index f = 0; f < cut.F.rows(); ++f)
    F.row(r++) << id[cut.F(f, 0)], id[cut.F(f, 1)], id[cut.F(f, 2)];
  s.F = std::move(F);
  for (const auto& [v, h] : apart) hint[static_cast<size_t>(v)] = h;
  return hint;
}

}  // namespace

bool crosses_fine_surfaces(const std::vector<EmbeddedSurface>& embedded, const BladeIndex& index) {
  if (index.tris.empty()) return false;
  for (const EmbeddedSurface& s : embedded)
    if (s.role != SurfaceRole::kWound && !crossed_triangles(s, index, /*first=*/true).empty())
      return true;
  return false;
}

std::vector<std::vector<Eigen::Vector3d>> split_embedded(
    const Eigen::MatrixX3d& X, const Tets& tets, const std::vector<int32_t>& star,
    const std::vector<Division>& divided, const Blade& rest_blade, const BladeIndex& index,
    std::vector<EmbeddedSurface>& embedded, bool without_divisions,
    const std::vector<Resplit>& resplit, std::vector<Eigen::Index>* had) {
  const Eigen::MatrixX4i& T = tets.T;
  std::vector<std::vector<Eigen::Vector3d>> hints(embedded.size());
  if (divided.empty() && !without_divisions) return hints;
  std::set<std::array<int32_t, 4>> corners;
  std::vector<uint8_t> is_divided(static_cast<size_t>(T.rows()), 0);
  for (const Division& d : divided) {
    const std::array<int32_t, 4> c = sorted_corners(T, d.tet);
    corners.insert(c);
    is_divided[static_cast<size_t>(d.tet)] = 1;
  }
  // The nodes around the cut: the divided tetrahedra's corners.
  std::vector<uint8_t> near(static_cast<size_t>(X.rows()), 0);
  for (const Division& d : divided)
    for (int k = 0; k < 4; ++k) near[static_cast<size_t>(T(d.tet, k))] = 1;
  // An earlier cut's two copies of a tetrahedron that still share their four nodes (glued to
  // whole tetrahedra at that cut's tip) open where this cut divides those: their vertices on the
  // blade are taken apart too.
  std::map<std::array<int32_t, 4>, int> seen;
  for (const int32_t t : star) {
    if (tets.share_of(t) >= 1.0) continue;
    const std::array<int32_t, 4> c = sorted_corners(T, t);
    if (++seen[c] == 2) corners.insert(c);
  }
  // (No tetrahedron divided, no star: the margins from the mean edge of the model's first
  // 1,000 tetrahedra.)
  double margin = 0.0;
  if (star.empty()) {
    const Eigen::Index n = std::min<Eigen::Index>(T.rows(), 1000);
    for (Eigen::Index t = 0; t < n; ++t) margin += (X.row(T(t, 1)) - X.row(T(t, 0))).norm();
    margin = n > 0 ? 0.5 * margin / static_cast<double>(n) : 0.0;
  }
  const Locator where(X, T, star, margin);
  Around around;
  for (const int32_t t : where.tets) {
    const std::array<int32_t, 4> c = sorted_corners(T, t);
    around.emplace(c, t);
  }
  // Earlier cuts' copies (their material is not their corners' mean).
  Around copies;
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    if (tets.share_of(t) >= 1.0) continue;
    const std::array<int32_t, 4> c = sorted_corners(T, t);
    copies.emplace(c, static_cast<int32_t>(t));
  }
  // Every tetrahedron near the blade, made when a split vertex is beyond `where`'s.
  std::optional<Locator> wide_one;
  std::once_flag wide_made;  // (the surfaces are split on the threads: made once, by the first)
  const auto wide = [&]() -> const Locator& {
    std::call_once(wide_made, [&] {
      const Eigen::AlignedBox3d reach(index.lo.array() - where.reach,
                                      index.hi.array() + where.reach);
      std::vector<int32_t> tets_near;
      for (Eigen::Index t = 0; t < T.rows(); ++t)
        if (tet_box(X, T, t).intersects(reach)) tets_near.push_back(static_cast<int32_t>(t));
      wide_one.emplace(X, T, tets_near, where.reach / 4.0);
    });
    return *wide_one;
  };
  const SurfaceMesh splitter = splitter_of(rest_blade);
  // The surfaces on the threads, each by one (the tetrahedra, the blade and the locators read
  // only; their own loops then run on that thread): the display skin and the structures a blade
  // crosses take a few milliseconds each (docs/benchmarks.md).
  std::vector<std::exception_ptr> failed(embedded.size());
#pragma omp parallel for schedule(dynamic, 1)
  for (size_t e = 0; e < embedded.size(); ++e) {
    if (embedded[e].role == SurfaceRole::kWound) continue;
    try {
      const Resplit* again =
          e < resplit.size() && resplit[e].unsplit != nullptr ? &resplit[e] : nullptr;
      bool seams_found = true;
      hints[e] = split_one(where, around, copies, tets, corners, is_divided, near, index, splitter,
                           wide, embedded[e], again, seams_found);
      if (seams_found) continue;
      // A seam's vertex not found (an earlier event's split of the triangle across it differs):
      // the surface made again as it was before the scalpel began, split along the whole path.
      log::debug("cut: {}: split again along the whole path (a seam did not match)",
                 embedded[e].name);
      unsplit_like(*again->unsplit, embedded[e]);
      if (had != nullptr) (*had)[e] = embedded[e].V.rows();
      hints[e] = split_one(where, around, copies, tets, corners, is_divided, near, index, splitter,
                           wide, embedded[e], nullptr, seams_found);
    } catch (...) {
      failed[e] = std::current_exception();
    }
  }
  for (const std::exception_ptr& f : failed)
    if (f) std::rethrow_exception(f);
  return hints;
}

}  // namespace lamina::model::detail
