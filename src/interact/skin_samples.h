#pragma once
// Internal to interact's contact files: the surface a tool touches (the skin, or a display skin
// the tetrahedra carry), the closest point of its triangles, sample points over it near a
// centre, and the merge of per-node force parts into a ForceRoute.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "lamina/geometry/closest_on_triangle.h"
#include "lamina/interact/contact.h"
#include "lamina/interact/skin_neighbourhood.h"
#include "lamina/interact/tools.h"
#include "lamina/model/model.h"

namespace lamina::interact::detail {

// A triangle surface whose vertices follow the nodes x: the skin (its vertices are the nodes
// 0..skin_nodes-1, rows of x) or a surface the tetrahedra carry (vertex v at
// sum_c W(v, c) x(corners(v, c))). Contact is found on it alike; a force at a point of it goes to
// its triangle's corners by barycentric weights and, on a carried surface, on to the nodes by W
// transposed. Both maps are affine with weights summing to 1, so the nodes receive the same
// total force and the same moment about any point as the surface did (but for a carried vertex
// with an offset, far outside the tetrahedra, whose load acts at its offset-free point).
struct SurfaceView {
  const Eigen::MatrixX3i& F;
  const Eigen::MatrixX3d& x;
  const EmbeddedSurface* carried = nullptr;
  int32_t skin_nodes = 0;  // the model's skin nodes (rows 0..skin_nodes-1 of x)

  Eigen::Vector3d vertex(int32_t v) const {
    if (!carried) return x.row(v).transpose();
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    for (int c = 0; c < 4; ++c)
      p += carried->weights(v, c) * x.row(carried->corners(v, c)).transpose();
    if (carried->offsets.rows() > v) p += carried->offsets.row(v).transpose();
    return p;
  }
  // Calls add(node, share) for each node that carries `share` of vertex v (itself, on the skin).
  template <class Add>
  void to_nodes(int32_t v, double share, Add&& add) const {
    if (!carried) return add(v, share);
    for (int c = 0; c < 4; ++c)
      if (carried->weights(v, c) != 0.0)
        add(carried->corners(v, c), share * carried->weights(v, c));
  }
  // The node that stands for vertex v as a marker: itself on the skin; on a carried surface its
  // heaviest skin corner (or heaviest corner, when none is on the skin).
  int32_t marker_node(int32_t v) const {
    if (!carried) return v;
    int32_t best = -1, any = -1;
    for (int c = 0; c < 4; ++c) {
      const int32_t n = carried->corners(v, c);
      const double w = carried->weights(v, c);
      if (any < 0 || w > carried->weights(v, any)) any = c;
      if (n < skin_nodes && (best < 0 || w > carried->weights(v, best))) best = c;
    }
    return carried->corners(v, best >= 0 ? best : any);
  }
};

// The skin (layer 0) at positions x.
inline SurfaceView skin_view(const Model& m, const Eigen::MatrixX3d& x) {
  return {.F = m.layers.at(0).F, .x = x, .skin_nodes = m.layers[0].node_count};
}

// The surface a tool touches at positions x: the model's display skin when it has one and
// `touch` asks for it, else the skin (layer 0). The model must have a skin.
SurfaceView touch_view(const Model& m, const Eigen::MatrixX3d& x, Touch touch);

// True when no point of the triangle can be within `reach` of `centre` (its bounding box is
// farther): the cheap test before closest_on_triangle.
inline bool box_out_of_reach(const Eigen::Vector3d& centre, double reach, const Eigen::Vector3d& a,
                             const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d lo = a.cwiseMin(b).cwiseMin(c), hi = a.cwiseMax(b).cwiseMax(c);
  const Eigen::Vector3d gap = (lo - centre).cwiseMax(centre - hi).cwiseMax(0.0);
  return gap.squaredNorm() > reach * reach;
}

// Calls visit(f) for each row f of F, or for each entry of `list` when one is given (the
// triangles a SkinNeighbourhood found near a point).
template <class Visit>
void for_faces(const Eigen::MatrixX3i& F, const std::vector<int32_t>* list, Visit&& visit) {
  if (list)
    for (const int32_t f : *list) visit(static_cast<Eigen::Index>(f));
  else
    for (Eigen::Index f = 0; f < F.rows(); ++f) visit(f);
}

// The point of the triangles F (rows index x; only the listed ones when `list` is given) nearest
// to p: brute force with a box reject per triangle (the skin moves every step, so a search tree
// would be rebuilt per query; a haptic tip asking every step keeps a SkinNeighbourhood).
inline SkinPoint closest_on_faces(const SurfaceView& s, const Eigen::Vector3d& p,
                                  const std::vector<int32_t>* list = nullptr) {
  const Eigen::MatrixX3i& F = s.F;
  SkinPoint best;
  for_faces(F, list, [&](Eigen::Index f) {
    const Eigen::Vector3d a = s.vertex(F(f, 0)), b = s.vertex(F(f, 1)), c = s.vertex(F(f, 2));
    if (best.face >= 0 && box_out_of_reach(p, best.distance_mm, a, b, c)) return;
    const Eigen::Vector3d w = geometry::closest_on_triangle(p, a, b, c);
    const Eigen::Vector3d q = w[0] * a + w[1] * b + w[2] * c;
    const double d = (q - p).norm();
    if (d < best.distance_mm)
      best = {.face = static_cast<int32_t>(f), .barycentric = w, .point_mm = q, .distance_mm = d};
  });
  return best;
}
inline SkinPoint closest_on_faces(const Eigen::MatrixX3i& F, const Eigen::MatrixX3d& x,
                                  const Eigen::Vector3d& p,
                                  const std::vector<int32_t>* list = nullptr) {
  return closest_on_faces(SurfaceView{.F = F, .x = x}, p, list);
}

// Calls visit(face, barycentric, point, area) at sample points of triangle f (corners a, b, c)
// when it comes within `reach` of `centre`. It is cut into k x k similar pieces (k^2 samples at
// the pieces' centroids, each standing for area / k^2), k = cuts(face, barycentric weights of its
// point nearest to the centre, that point's distance, the triangle's longest edge), clamped to
// 1..16.
template <class Cuts, class Visit>
void sample_triangle(int32_t f, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                     const Eigen::Vector3d& c, const Eigen::Vector3d& centre, double reach,
                     Cuts&& cuts, Visit&& visit) {
  const Eigen::Vector3d w = geometry::closest_on_triangle(centre, a, b, c);
  const double distance = (w[0] * a + w[1] * b + w[2] * c - centre).norm();
  if (distance > reach) return;
  const double longest =
      std::sqrt(std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()}));
  const int k = std::clamp(cuts(f, w, distance, longest), 1, 16);
  const double area = 0.5 * (b - a).cross(c - a).norm() / (k * k);
  const double inv = 1.0 / k;
  for (int i = 0; i < k; ++i)
    for (int j = 0; i + j < k; ++j) {
      // The piece with corners (i, j), (i + 1, j), (i, j + 1) in steps of 1/k along b and c,
      // and, unless at the far edge, the flipped piece beside it.
      for (int flip = 0; flip < (i + j + 1 < k ? 2 : 1); ++flip) {
        const double third = flip ? 2.0 / 3.0 : 1.0 / 3.0;
        const double wb = (i + third) * inv, wc = (j + third) * inv;
        const Eigen::Vector3d bary(1.0 - wb - wc, wb, wc);
        visit(f, bary, Eigen::Vector3d(a + wb * (b - a) + wc * (c - a)), area);
      }
    }
}

// sample_triangle over every triangle of F (rows index x: the skin, or a finite-element mesh's
// boundary) that comes within `reach` of `centre`.
template <class Cuts, class Visit>
void sample_faces_near(const Eigen::MatrixX3i& F, const Eigen::MatrixX3d& x,
                       const Eigen::Vector3d& centre, double reach, Cuts&& cuts, Visit&& visit) {
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = x.row(F(f, 0)), b = x.row(F(f, 1)), c = x.row(F(f, 2));
    if (box_out_of_reach(centre, reach, a, b, c)) continue;
    sample_triangle(static_cast<int32_t>(f), a, b, c, centre, reach, cuts, visit);
  }
}

// Triangles of a surface with their corners and bounding boxes at the current positions,
// gathered once for queries that visit them many times (a haptic proxy's moves and its load's
// patch): a display skin's corner costs four gathers (W x). Reused: no allocation once grown.
struct Gathered {
  std::vector<int32_t> face;
  std::vector<Eigen::Vector3d> a, b, c, lo, hi;

  // The triangles (all of s's, or the listed ones) whose boxes come within `reach` of `centre`.
  void gather(const SurfaceView& s, const std::vector<int32_t>* list, const Eigen::Vector3d& centre,
              double reach) {
    clear();
    for_faces(s.F, list, [&](Eigen::Index f) {
      keep(static_cast<int32_t>(f), s.vertex(s.F(f, 0)), s.vertex(s.F(f, 1)), s.vertex(s.F(f, 2)),
           centre, reach);
    });
  }
  // The triangles `near` lists (faces_near's last answer for s) within `reach` of `centre`; on a
  // carried surface each listed vertex's W x is computed once, into `scratch`.
  void gather_listed(const SurfaceView& s, const SkinNeighbourhood& near,
                     const Eigen::Vector3d& centre, double reach,
                     std::vector<Eigen::Vector3d>& scratch) {
    if (!s.carried) return gather(s, &near.faces, centre, reach);
    scratch.resize(near.vertices.size());
    for (size_t v = 0; v < near.vertices.size(); ++v) scratch[v] = s.vertex(near.vertices[v]);
    clear();
    const auto corner = [&](size_t k) -> const Eigen::Vector3d& {
      return scratch[static_cast<size_t>(near.local_corners[k])];
    };
    for (size_t k = 0; k < near.faces.size(); ++k)
      keep(near.faces[k], corner(3 * k), corner(3 * k + 1), corner(3 * k + 2), centre, reach);
  }
  size_t size() const { return face.size(); }
  // True when no point of entry k is within `reach` of p.
  bool out_of_reach(size_t k, const Eigen::Vector3d& p, double reach) const {
    return (lo[k] - p).cwiseMax(p - hi[k]).cwiseMax(0.0).squaredNorm() > reach * reach;
  }

 private:
  void clear() { face.clear(), a.clear(), b.clear(), c.clear(), lo.clear(), hi.clear(); }
  // Triangle f (corners p, q, r) as an entry, when its box comes within `reach` of `centre`.
  void keep(int32_t f, const Eigen::Vector3d& p, const Eigen::Vector3d& q, const Eigen::Vector3d& r,
            const Eigen::Vector3d& centre, double reach) {
    if (box_out_of_reach(centre, reach, p, q, r)) return;
    face.push_back(f), a.push_back(p), b.push_back(q), c.push_back(r);
    lo.push_back(p.cwiseMin(q).cwiseMin(r)), hi.push_back(p.cwiseMax(q).cwiseMax(r));
  }
};

// spread_on_patch on the surface s (`at` a point of it).
ForceRoute spread_on_surface(const SurfaceView& s, const SkinPoint& at,
                             const Eigen::Vector3d& force_mn, double radius_mm);

// The same over gathered triangles (a superset of those within radius_mm of the contact point),
// for a caller that has gathered them already.
ForceRoute spread_on_gathered(const SurfaceView& s, const Gathered& g, const SkinPoint& at,
                              const Eigen::Vector3d& force_mn, double radius_mm);

// skin_faces_near on the surface s.
const std::vector<int32_t>& faces_near(const SurfaceView& s, const Eigen::Vector3d& centre,
                                       double reach, SkinNeighbourhood& near);

// How far p is under the surface s, mm (depth_under_skin on s). `scratch` holds a carried
// surface's vertex positions for the winding number.
double depth_under(const SurfaceView& s, const Eigen::Vector3d& p, Eigen::MatrixX3d& scratch);

// Cuts so that a piece is no wider than `spacing` (mm) on an edge of length `longest`.
inline int cuts_for(double longest, double spacing) {
  return spacing > 0.0 ? static_cast<int>(std::min(std::ceil(longest / spacing), 16.0)) : 16;
}

// Per-node force parts merged into a route (nodes ascending, each once). `parts` is reused
// scratch: sorted in place.
inline void merge_parts(std::vector<std::pair<int32_t, Eigen::Vector3d>>& parts, ForceRoute& out) {
  std::sort(parts.begin(), parts.end(),
            [](const auto& l, const auto& r) { return l.first < r.first; });
  out.nodes.clear();
  for (const auto& part : parts)
    if (out.nodes.empty() || out.nodes.back() != part.first) out.nodes.push_back(part.first);
  out.forces.setZero(static_cast<Eigen::Index>(out.nodes.size()), 3);
  Eigen::Index row = -1;
  int32_t last = -1;
  for (const auto& [node, f] : parts) {
    if (node != last) ++row, last = node;
    out.forces.row(row) += f.transpose();
  }
}

}  // namespace lamina::interact::detail
