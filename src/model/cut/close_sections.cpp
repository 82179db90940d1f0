// After a cut has split the fine surfaces and their vertices follow their copies: the two sides'
// vertices of a point where the tissue did not open welded again, and each section the cut closed
// off on one side (a vessel cut across, a piece cut off) capped with CGAL's hole filling
// (geometry::fill_loop).
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <map>
#include <set>
#include <unordered_map>

#include "cut_internal.h"
#include "lamina/geometry/split_surface.h"

namespace lamina::model::detail {

std::vector<int32_t> keep_vertices(EmbeddedSurface& s, Eigen::Index first,
                                   const std::vector<uint8_t>& keep) {
  std::vector<int32_t> to(static_cast<size_t>(s.V.rows()), -1);
  Eigen::Index n = 0;
  for (Eigen::Index v = 0; v < s.V.rows(); ++v) {
    if (v >= first && !keep[static_cast<size_t>(v)]) continue;
    to[static_cast<size_t>(v)] = static_cast<int32_t>(n);
    if (n != v) {
      s.V.row(n) = s.V.row(v), s.corners.row(n) = s.corners.row(v);
      s.weights.row(n) = s.weights.row(v);
      if (s.offsets.rows() > 0) s.offsets.row(n) = s.offsets.row(v);
    }
    ++n;
  }
  s.V.conservativeResize(n, 3), s.corners.conservativeResize(n, 4);
  s.weights.conservativeResize(n, 4);
  if (s.offsets.rows() > 0) s.offsets.conservativeResize(n, 3);
  return to;
}

void close_sections(std::vector<EmbeddedSurface>& embedded, const std::vector<Eigen::Index>& had,
                    const BladeIndex& index, const std::vector<Eigen::Index>* made) {
  for (size_t e = 0; e < embedded.size() && e < had.size(); ++e) {
    EmbeddedSurface& s = embedded[e];
    const Eigen::Index first_new = had[e];
    if (s.V.rows() == first_new) continue;  // nothing split here
    // A section's loop may run through vertices earlier events of a progressive cut made (a split
    // along its new part only): the boundary is looked for among all of them.
    const Eigen::Index first_made =
        made != nullptr && e < made->size() ? std::min((*made)[e], first_new) : first_new;
    // Welded again: the two sides' vertices of a point where the tissue did not open after all
    // (the same copy's nodes and weights) are one.
    std::map<std::array<double, 11>, int32_t> same;
    std::vector<int32_t> to(static_cast<size_t>(s.V.rows()));
    for (Eigen::Index v = 0; v < s.V.rows(); ++v) {
      to[static_cast<size_t>(v)] = static_cast<int32_t>(v);
      if (v < first_new) continue;
      std::array<double, 11> key{};
      for (int k = 0; k < 3; ++k) key[k] = s.V(v, k);
      for (int k = 0; k < 4; ++k) key[3 + k] = s.corners(v, k), key[7 + k] = s.weights(v, k);
      to[static_cast<size_t>(v)] = same.try_emplace(key, static_cast<int32_t>(v)).first->second;
    }
    // The triangles with a vertex this split made: the only ones the welding, the dropping and
    // the new boundary below touch (a display skin's other 100,000 were passed over three times
    // an event).
    std::vector<Eigen::Index> touched;
    for (Eigen::Index f = 0; f < s.F.rows(); ++f)
      if (s.F(f, 0) >= first_made || s.F(f, 1) >= first_made || s.F(f, 2) >= first_made)
        touched.push_back(f);
    // The new vertices no triangle has any more are dropped (nothing outside knows them yet).
    std::vector<uint8_t> used(static_cast<size_t>(s.V.rows()), 0);
    for (const Eigen::Index f : touched)
      for (int k = 0; k < 3; ++k) used[static_cast<size_t>(to[static_cast<size_t>(s.F(f, k))])] = 1;
    const std::vector<int32_t> keep = keep_vertices(s, first_new, used);
    // A triangle two of whose corners were welded had no area: it goes (its neighbours across
    // the welded edge meet instead). The others keep their order; `touched` follows them.
    std::vector<uint8_t> gone(touched.size(), 0);
    bool any_gone = false;
    for (size_t q = 0; q < touched.size(); ++q) {
      const Eigen::Index f = touched[q];
      Eigen::RowVector3i g;
      for (int k = 0; k < 3; ++k)
        g[k] = keep[static_cast<size_t>(to[static_cast<size_t>(s.F(f, k))])];
      s.F.row(f) = g;
      gone[q] = !(g[0] != g[1] && g[1] != g[2] && g[0] != g[2]);
      any_gone = any_gone || gone[q];
    }
    if (any_gone) {
      Eigen::Index kept = 0;
      size_t q = 0, out = 0;
      for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
        const bool is_touched = q < touched.size() && touched[q] == f;
        if (is_touched && gone[q++]) continue;
        if (is_touched) touched[out++] = kept;
        s.F.row(kept++) = s.F.row(f);
      }
      touched.resize(out);
      s.F.conservativeResize(kept, 3);
    }

    // The boundary the cut made: each edge with a new end in one triangle only (every triangle
    // with such an edge has the new vertex), from its start.
    std::unordered_map<uint64_t, int> count;
    const auto fresh_edge = [&](int32_t a, int32_t b) {
      return a >= first_made || b >= first_made;
    };
    for (const Eigen::Index f : touched)
      for (int k = 0; k < 3; ++k)
        if (fresh_edge(s.F(f, k), s.F(f, (k + 1) % 3)))
          ++count[edge_key(s.F(f, k), s.F(f, (k + 1) % 3))];
    std::unordered_map<int32_t, int32_t> next;
    std::unordered_map<int32_t, Eigen::Index>
        face_of;  // the triangle of a boundary edge, by its start
    std::set<int32_t> pinched;
    for (const Eigen::Index f : touched)
      for (int k = 0; k < 3; ++k) {
        const int32_t a = s.F(f, k), b = s.F(f, (k + 1) % 3);
        if (!fresh_edge(a, b) || count[edge_key(a, b)] != 1) continue;
        if (!next.emplace(a, b).second) pinched.insert(a);
        face_of[a] = f;
      }
    // Which side of the blade a boundary edge's triangle is on: +1, -1, 0 (unknown).
    const auto side_of = [&](int32_t a) {
      const Eigen::Vector3d p = s.V.row(a).transpose();
      const int k = blade_triangle_at(index, p, 1e-6);
      if (k < 0) return 0;
      const BladeTriangle& t = index.tris[static_cast<size_t>(k)];
      const Eigen::Index f = face_of.at(a);
      const Eigen::Vector3d c =
          (s.V.row(s.F(f, 0)) + s.V.row(s.F(f, 1)) + s.V.row(s.F(f, 2))).transpose() / 3.0;
      const double d = t.n.dot(c - t.p0);
      return d > 1e-9 ? 1 : (d < -1e-9 ? -1 : 0);
    };
    // Each loop with a vertex this cut made, on one side only (no point twice: a slit's loop
    // runs down one side and back up the other), is a section: capped.
    std::vector<Eigen::RowVector3i> caps;
    std::set<int32_t> seen;
    for (const auto& [start, unused] : next) {
      if (seen.count(start)) continue;
      std::vector<int32_t> loop;
      bool ok = true;
      for (int32_t v = start;;) {
        if (!seen.insert(v).second) {
          ok = ok && v == start;
          break;
        }
        if (pinched.count(v)) ok = false;
        loop.push_back(v);
        const auto it = next.find(v);
        if (it == next.end()) {
          ok = false;
          break;
        }
        v = it->second;
      }
      if (!ok || loop.size() < 3) continue;
      bool fresh = false;
      std::set<std::array<double, 3>> points;
      std::set<int> sides;
      for (const int32_t v : loop) {
        // (Made by this cut, or by an earlier event of the same scalpel: a section an earlier
        // event left open where the tissue had not opened, its side's vertices kept as they were
        // when the tissue opens now, the other side's taken apart.)
        fresh |= v >= first_made;
        ok &= points.insert({s.V(v, 0), s.V(v, 1), s.V(v, 2)}).second;
        sides.insert(side_of(v));
      }
      // (On the blade, every triangle on one side of it.)
      ok &= sides.size() == 1 && *sides.begin() != 0;
      if (!fresh || !ok) continue;
      Eigen::MatrixX3d P(static_cast<Eigen::Index>(loop.size()), 3);
      for (size_t k = 0; k < loop.size(); ++k)
        P.row(static_cast<Eigen::Index>(k)) = s.V.row(loop[k]);
      const Eigen::MatrixX3i cap = geometry::fill_loop(P);
      for (Eigen::Index f = 0; f < cap.rows(); ++f)
        caps.emplace_back(loop[cap(f, 0)], loop[cap(f, 1)], loop[cap(f, 2)]);
    }
    if (caps.empty()) continue;
    const Eigen::Index nf = s.F.rows();
    s.F.conservativeResize(nf + static_cast<Eigen::Index>(caps.size()), 3);
    for (size_t f = 0; f < caps.size(); ++f) s.F.row(nf + static_cast<Eigen::Index>(f)) = caps[f];
  }
}

}  // namespace lamina::model::detail
