#pragma once
// What model::cut_tetrahedra's steps pass each other (private to src/model/cut).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

#include "../find_spring.h"
#include "lamina/model/cut_tetrahedra.h"

namespace lamina::model::detail {

/// One key per undirected edge: its lower node in the high half.
inline uint64_t edge_key(int32_t a, int32_t b) {
  const auto lo = static_cast<uint32_t>(std::min(a, b)), hi = static_cast<uint32_t>(std::max(a, b));
  return (static_cast<uint64_t>(lo) << 32) | hi;
}

/// Tetrahedron t's bounding box at positions x.
inline Eigen::AlignedBox3d tet_box(const Eigen::MatrixX3d& x, const Eigen::MatrixX4i& T,
                                   Eigen::Index t) {
  Eigen::AlignedBox3d b;
  for (int k = 0; k < 4; ++k) b.extend(x.row(T(t, k)).transpose());
  return b;
}

/// Where the blade crosses the tetrahedra's edges: for each edge it crosses an odd number of
/// times, the first crossing's fraction along the edge from its lower-numbered node.
struct Crossings {
  std::unordered_map<uint64_t, double> at;
  std::vector<int32_t> near_tets;  ///< tetrahedra whose bounding box meets the blade's

  /// The crossing's fraction from node `from` towards node `to`, or -1 when not crossed.
  double fraction(int32_t from, int32_t to) const {
    const auto it = at.find(edge_key(from, to));
    if (it == at.end()) return -1.0;
    return from < to ? it->second : 1.0 - it->second;
  }
};

/// A blade's triangles ready for segment tests.
struct BladeTriangle {
  Eigen::Vector3d p0, e1, e2, n;  ///< corner, edges from it, unit normal
  Eigen::Vector3d lo, hi;         ///< bounding box
};
struct BladeIndex {
  std::vector<BladeTriangle> tris;  ///< the blade's triangles with area
  Eigen::Vector3d lo = Eigen::Vector3d::Zero(), hi = Eigen::Vector3d::Zero();  ///< their box
  double eps = 0.0;  ///< a point this close to a triangle's plane counts as on its positive side
};
BladeIndex index_blade(const Blade& blade);

/// Whether q (a point in t's plane, relative to t.p0) lies in blade triangle t: its barycentric
/// coordinates are all >= -tol (a triangle without area holds nothing).
inline bool in_triangle(const BladeTriangle& t, const Eigen::Vector3d& q, double tol) {
  const double d00 = t.e1.dot(t.e1), d01 = t.e1.dot(t.e2), d11 = t.e2.dot(t.e2);
  const double d20 = q.dot(t.e1), d21 = q.dot(t.e2), det = d00 * d11 - d01 * d01;
  if (!(det > 0.0)) return false;
  const double v = (d11 * d20 - d01 * d21) / det, w = (d00 * d21 - d01 * d20) / det;
  return v >= -tol && w >= -tol && v + w <= 1.0 + tol;
}

/// Every fraction along a -> b where the segment crosses a blade triangle, ascending, a crossing
/// on the edge two triangles share once. A point on a triangle's plane (within eps) counts as on
/// its positive side, so that an edge through a node on the blade is crossed once, by the edges
/// on the node's other side, and a cut through vertices divides the tetrahedra around it
/// consistently.
void edge_hits(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const BladeIndex& blade,
               std::vector<double>& hits);

/// Where the blade crosses each embedded structure (every embedded surface but the display
/// skin, at the positions x): one entry per closed loop of its crossing (a vessel cut across).
/// Only the structures' triangles meeting the box [near_lo, near_hi] are looked at.
std::vector<StructureCut> structures_crossed(const Model& model, const Eigen::MatrixX3d& x,
                                             const BladeIndex& blade,
                                             const Eigen::Vector3d& near_lo,
                                             const Eigen::Vector3d& near_hi);

/// Finds the edges of the tetrahedra T (at positions x) that the blade crosses.
Crossings blade_crossings(const Eigen::MatrixX3d& x, const Eigen::MatrixX4i& T,
                          const BladeIndex& blade);

/// A tetrahedron the blade divides.
struct Division {
  int32_t tet = 0;
  uint8_t side = 0;    ///< corner bitmask of one side (the other is its complement)
  double share = 0.0;  ///< that side's share of the material, [kMinCutShare, 1 - kMinCutShare]
};

/// The tetrahedra the crossings divide into two sides (every edge between the sides crossed,
/// none within a side), and how many they cross without dividing.
void divide_tets(const Eigen::MatrixX4i& T, const Crossings& crossings,
                 std::vector<Division>& divided, int64_t& partly);

/// Adds the cut's wound to the embedded surface kWoundName of `embedded` (made if absent): per
/// divided tetrahedron (divided[k], whose copies in the cut model are first_copy[k], carrying
/// its side, and first_copy[k] + 1), the polygon through the crossings of its edges between the
/// sides at rest, on each copy, facing out of that copy's material, its corners embedded on the
/// copy's edges (cut_T: the cut model's tetrahedra); one mesh per side, sharing vertices where
/// copies share nodes.
void add_wound(const Eigen::MatrixX3d& X, const Eigen::MatrixX4i& T,
               const std::vector<Division>& divided, const std::vector<int32_t>& first_copy,
               const Crossings& crossings, const Eigen::MatrixX4i& cut_T,
               std::vector<EmbeddedSurface>& embedded);

/// The embedded surfaces (all but the wound) split exactly along the blade at rest where the
/// tetrahedra `divided` open (geometry::split_surface on the triangles whose edges the blade
/// crosses inside divided tetrahedra; a triangle it crosses elsewhere stays whole). The new
/// vertices are appended, embedded in the rest tetrahedra (of `tets`, among `star`) that hold
/// them, on their side (an earlier cut's copies by the material they carry).
/// `index`: rest_blade's (index_blade()). Returns per surface and vertex a point at rest on its
/// side of the cut for the vertices on it (NaN for the others): which copy it follows.
/// `without_divisions`: split though `divided` is empty (the surfaces outside the tissue a
/// progressive scalpel passes after it has left it; their new vertices follow whole tetrahedra
/// on their side).
/// A progressive cut's surface to be split along its path's new part only (drop_resplit_part).
struct Resplit {
  const EmbeddedSurface* unsplit = nullptr;  ///< the surface before the scalpel began
  /// Its triangles to split (their vertices are the first rows of the model's surface)
  std::vector<Eigen::RowVector3i> faces;
  /// Their edges shared with a crossed triangle that stays as earlier events split it: the
  /// split's new vertices there are those triangles' (matched by position and side)
  std::vector<std::pair<int32_t, int32_t>> seams;
  /// The blade's new part (index_blade()): a vertex beside the organ whose tetrahedron's material
  /// lies across the blade's earlier part was moved to its side at an earlier event
  const BladeIndex* fresh = nullptr;
};

/// `resplit` (per surface of `embedded`, or empty): where a surface has an unsplit one, its
/// triangles `faces` are split along the blade, their vertices on the seams being the surface's
/// own, in place of the triangles the blade crosses; where that cannot be (a seam's vertex not
/// found), the surface is made again from its unsplit one and split afresh, `had` (each
/// surface's vertex count before the split) following.
std::vector<std::vector<Eigen::Vector3d>> split_embedded(
    const Eigen::MatrixX3d& X, const Tets& tets, const std::vector<int32_t>& star,
    const std::vector<Division>& divided, const Blade& rest_blade, const BladeIndex& index,
    std::vector<EmbeddedSurface>& embedded, bool without_divisions = false,
    const std::vector<Resplit>& resplit = {}, std::vector<Eigen::Index>* had = nullptr);

/// The triangles of s with an edge the blade crosses strictly inside (the first only, with
/// `first`), each edge tested once.
std::vector<Eigen::Index> crossed_triangles(const EmbeddedSurface& s, const BladeIndex& index,
                                            bool first = false);

/// Drops s's vertices from `first` on that `keep` says not to (per vertex), the others moved
/// down in order; returns each vertex's new index (-1: dropped). Triangles are not touched.
std::vector<int32_t> keep_vertices(EmbeddedSurface& s, Eigen::Index first,
                                   const std::vector<uint8_t>& keep);

/// s made again as the unsplit surface u, its vertices (s's first rows) where s's are embedded.
void unsplit_like(const EmbeddedSurface& u, EmbeddedSurface& s);

/// For a progressive cut whose surfaces have been split along the blade `whole` but for its new
/// part `fresh` (both at rest): drops from s (the model's surface, whose first rows are u's
/// vertices) what earlier splits made of u's triangles that `whole` crosses and `fresh` reaches
/// (each sub-triangle lies in its triangle), and the caps of sections through them, with the
/// split-made vertices nothing else keeps; returns those triangles, to be split again.
Resplit drop_resplit_part(const EmbeddedSurface& u, const BladeIndex& whole,
                          const BladeIndex& fresh, EmbeddedSurface& s);

/// Whether the blade crosses an edge of a fine surface (any embedded surface but the wound)
/// strictly inside.
bool crosses_fine_surfaces(const std::vector<EmbeddedSurface>& embedded, const BladeIndex& index);

/// The blade triangle over p (p's projection on its plane inside it) within `reach` of p, the
/// nearest such, or -1.
int blade_triangle_at(const BladeIndex& index, const Eigen::Vector3d& p, double reach);

/// The centroid of the corners tetrahedron t carries material at (all four for a whole one).
Eigen::Vector3d material_centre(const Eigen::MatrixX3d& X, const Eigen::MatrixX4i& T,
                                const Tets& tets, int32_t t);

/// After split_embedded() and the vertices' move to their copies: the new vertices of a point
/// that did not open (the same nodes and weights) welded again, and each boundary loop the cut
/// made that lies on one side only (a vessel cut across, a piece cut off: not a slit, which runs
/// down one side and back up the other) capped (geometry::fill_loop). `had`: each surface's
/// vertex count before the split.
/// `index`: the blade at rest (a section lies on it, its triangles on one side of it).
/// `made` (if given): each surface's first vertex any split of this scalpel made (a section's loop
/// may run through vertices earlier events made; else `had`).
void close_sections(std::vector<EmbeddedSurface>& embedded, const std::vector<Eigen::Index>& had,
                    const BladeIndex& index, const std::vector<Eigen::Index>* made = nullptr);

/// The share of a tetrahedron's volume on the side `side` (corner bitmask) of a cut crossing
/// each edge from corner i (on the side) to corner j (off it) at fraction s[i][j] from i: exact
/// for a planar cut.
double side_share(uint8_t side, const double s[4][4]);

}  // namespace lamina::model::detail
