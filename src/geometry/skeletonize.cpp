// The curve skeleton of a mask (skeletonize.h) by distance-ordered homotopic thinning, after
// Pudney, "Distance-ordered homotopic thinning: a skeletonization algorithm for 3D digital
// images" (CVIU 72, 1998), with the simple-point test of Bertrand and Malandain, "A new
// characterization of three-dimensional simple points" (Pattern Recognition Letters 15, 1994).
// Written by hand: ITK 5.2 as Debian packages it has only a 2-D thinning (the 3-D one is a remote
// module), and CGAL's mean-curvature-flow skeleton needs a surface mesh of the vessels first
// (docs/architecture.md, "Vessel centrelines").
#include "lamina/geometry/skeletonize.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <utility>

#include "distance_transform.h"

namespace lamina::geometry {
namespace {

constexpr int kCentre = 13;
constexpr uint32_t kCentreBit = 1u << kCentre;
// A voxel is off the medial axis when the distance to the background grows towards a neighbour
// by this fraction of the step or more (1 from a surface straight in; a vessel tapers by much
// less along its axis).
constexpr double kMedialSlope = 0.6;
// A terminal branch shorter than this times the radius where it joins is a spur of the surface.
constexpr double kSpurLength = 1.5;
// A curve's end whose radius grows inwards by this much a millimetre or more is bent off the
// axis, along a flat end's medial sheet to its rim.
constexpr double kBentEndSlope = 0.4;

int position(int dx, int dy, int dz) {
  return (dx + 1) + 3 * (dy + 1) + 9 * (dz + 1);
}

// The 3 x 3 x 3 cube's adjacencies as bit masks, the centre left out of every one.
struct CubeTables {
  std::array<uint32_t, 27> adj26{};  // each position's 26-neighbours in the cube
  std::array<uint32_t, 27> adj6{};   // each position's 6-neighbours in the cube
  uint32_t n18 = 0;                  // the centre's 18 face and edge neighbours
  uint32_t faces = 0;                // the centre's 6 face neighbours

  CubeTables() {
    for (int z = -1; z <= 1; ++z)
      for (int y = -1; y <= 1; ++y)
        for (int x = -1; x <= 1; ++x) {
          const int p = position(x, y, z);
          const int l1 = std::abs(x) + std::abs(y) + std::abs(z);
          if (l1 == 1) faces |= 1u << p;
          if (l1 == 1 || l1 == 2) n18 |= 1u << p;
          for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
              for (int dx = -1; dx <= 1; ++dx) {
                const int qx = x + dx, qy = y + dy, qz = z + dz;
                if ((dx | dy | dz) == 0 || std::abs(qx) > 1 || std::abs(qy) > 1 || std::abs(qz) > 1)
                  continue;
                const int q = position(qx, qy, qz);
                if (q == kCentre) continue;
                adj26[static_cast<size_t>(p)] |= 1u << q;
                if (std::abs(dx) + std::abs(dy) + std::abs(dz) == 1)
                  adj6[static_cast<size_t>(p)] |= 1u << q;
              }
        }
  }
};

const CubeTables& tables() {
  static const CubeTables t;
  return t;
}

// The component of `set` that holds `seed`, under adjacency `adj`.
uint32_t grow(uint32_t seed, uint32_t set, const std::array<uint32_t, 27>& adj) {
  uint32_t component = seed;
  uint32_t frontier = seed;
  while (frontier != 0) {
    uint32_t next = 0;
    for (uint32_t f = frontier; f != 0; f &= f - 1)
      next |= adj[static_cast<size_t>(std::countr_zero(f))];
    next &= set & ~component;
    component |= next;
    frontier = next;
  }
  return component;
}

// The mask's bounding box with one voxel of background around it, which may lie outside the
// grid (read as background).
struct Box {
  std::array<int64_t, 3> lo{}, n{};
  int64_t count() const { return n[0] * n[1] * n[2]; }
};

Box padded_box(const Mask& mask) {
  const GridFrame& f = mask.frame;
  std::array<int64_t, 3> lo{f.size[0], f.size[1], f.size[2]}, hi{-1, -1, -1};
  for (int64_t k = 0; k < f.size[2]; ++k)
    for (int64_t j = 0; j < f.size[1]; ++j) {
      const uint8_t* row = mask.inside.data() + f.index(0, j, k);
      for (int64_t i = 0; i < f.size[0]; ++i)
        if (row[i] != 0) {
          const std::array<int64_t, 3> v{i, j, k};
          for (int a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], v[a]);
            hi[a] = std::max(hi[a], v[a]);
          }
        }
    }
  Box b;
  for (int a = 0; a < 3; ++a) {
    b.lo[a] = lo[a] - 1;
    b.n[a] = hi[a] < lo[a] ? 0 : hi[a] - lo[a] + 3;
  }
  return b;
}

}  // namespace

bool is_simple_point(uint32_t cube) {
  const CubeTables& t = tables();
  const uint32_t foreground = cube & ((1u << 27) - 1) & ~kCentreBit;
  if (foreground == 0) return false;  // an isolated voxel: removing it removes a component
  // One 26-connected foreground component among the 26 neighbours.
  if (grow(foreground & (~foreground + 1), foreground, t.adj26) != foreground) return false;
  // One 6-connected background component of the 18-neighbourhood that touches the centre's
  // faces (none: the voxel is inside, and removing it would make a cavity).
  const uint32_t background = ~cube & t.n18;
  const uint32_t open_faces = background & t.faces;
  if (open_faces == 0) return false;
  const uint32_t reached = grow(open_faces & (~open_faces + 1), background, t.adj6);
  return (reached & open_faces) == open_faces;
}

Skeleton skeletonize(const Mask& mask) {
  Skeleton out;
  out.frame = mask.frame;
  const Box box = padded_box(mask);
  if (box.count() == 0) return out;
  const GridFrame& f = mask.frame;

  // The box as a grid of its own (same spacing): the mask inside it, and each foreground voxel's
  // distance to the background.
  GridFrame bf = f;
  bf.size = box.n;
  std::vector<uint8_t> in(static_cast<size_t>(box.count()), 0);
  std::vector<uint8_t> outside(in.size(), 1);
  for (int64_t k = 1; k + 1 < box.n[2]; ++k)
    for (int64_t j = 1; j + 1 < box.n[1]; ++j)
      for (int64_t i = 1; i + 1 < box.n[0]; ++i) {
        const int64_t b = bf.index(i, j, k);
        in[static_cast<size_t>(b)] =
            mask.inside[static_cast<size_t>(f.index(i + box.lo[0], j + box.lo[1], k + box.lo[2]))];
        outside[static_cast<size_t>(b)] = in[static_cast<size_t>(b)] != 0 ? 0 : 1;
      }
  const std::vector<float> depth = detail::distance_to_foreground(bf, outside);
  outside = {};

  std::array<int64_t, 27> offset{};
  for (int z = -1; z <= 1; ++z)
    for (int y = -1; y <= 1; ++y)
      for (int x = -1; x <= 1; ++x)
        offset[static_cast<size_t>(position(x, y, z))] = x + bf.size[0] * (y + bf.size[1] * z);
  const auto cube_of = [&](int64_t v) {
    uint32_t c = 0;
    for (int q = 0; q < 27; ++q)
      if (in[static_cast<size_t>(v + offset[static_cast<size_t>(q)])] != 0) c |= 1u << q;
    return c;
  };
  const uint32_t faces = tables().faces;

  // Where a curve may end: voxels on the medial axis, the centres of balls no neighbour's ball
  // holds. The distance grows by the whole step into a thick tube from its surface and from its
  // cap, by less along a tapering vessel's axis; a curve end off the axis is a spur of the
  // surface's voxels, thinned away.
  std::array<double, 27> step_mm{};
  for (int z = -1; z <= 1; ++z)
    for (int y = -1; y <= 1; ++y)
      for (int x = -1; x <= 1; ++x)
        step_mm[static_cast<size_t>(position(x, y, z))] =
            std::hypot(x * f.spacing_mm[0], y * f.spacing_mm[1], z * f.spacing_mm[2]);
  const auto medial = [&](int64_t v) {
    const float d = depth[static_cast<size_t>(v)];
    for (int q = 0; q < 27; ++q) {
      if (q == kCentre) continue;
      const float dq = depth[static_cast<size_t>(v + offset[static_cast<size_t>(q)])];
      if (dq - d >= kMedialSlope * step_mm[static_cast<size_t>(q)]) return false;
    }
    return true;
  };

  // The first pass's candidates: every foreground voxel with a background face neighbour. The
  // box's padding keeps every foreground voxel's cube inside the box.
  std::vector<int64_t> border, next;
  std::vector<uint8_t> queued(in.size(), 0);
  for (int64_t v = 0; v < static_cast<int64_t>(in.size()); ++v)
    if (in[static_cast<size_t>(v)] != 0 && (~cube_of(v) & faces) != 0) {
      border.push_back(v);
      queued[static_cast<size_t>(v)] = 1;
    }
  while (!border.empty()) {
    // Nearest the background first; ties by index, so that the result is the same every run.
    std::sort(border.begin(), border.end(), [&](int64_t a, int64_t b) {
      const float da = depth[static_cast<size_t>(a)], db = depth[static_cast<size_t>(b)];
      return da < db || (da == db && a < b);
    });
    next.clear();
    int64_t removed = 0;
    for (const int64_t v : border) {
      queued[static_cast<size_t>(v)] = 0;
      const uint32_t c = cube_of(v);
      // The end of a curve on the medial axis stays (and an isolated voxel: a component).
      const int neighbours = std::popcount(c & ~kCentreBit);
      if (neighbours == 0 || (neighbours == 1 && medial(v)) || !is_simple_point(c)) continue;
      in[static_cast<size_t>(v)] = 0;
      ++removed;
      for (int q = 0; q < 27; ++q) {  // its neighbours: the next pass's candidates
        const int64_t w = v + offset[static_cast<size_t>(q)];
        if (in[static_cast<size_t>(w)] != 0 && queued[static_cast<size_t>(w)] == 0) {
          queued[static_cast<size_t>(w)] = 1;
          next.push_back(w);
        }
      }
    }
    ++out.passes;
    if (removed == 0) break;
    std::swap(border, next);
  }

  // Spurs. The medial axis of a tube reaches the rim of a flat cap (and of a bump of its
  // surface) in sheets, and the thinning keeps a curve's end wherever the axis goes: a terminal
  // branch shorter than kSpurLength times the radius where it joins the rest is such a spur and
  // goes. A curve without a junction no longer than its widest radius is a blob's: its widest
  // voxel stays.
  std::vector<int64_t> skeleton;
  for (int64_t v = 0; v < static_cast<int64_t>(in.size()); ++v)
    if (in[static_cast<size_t>(v)] != 0) skeleton.push_back(v);
  std::vector<int64_t> branch;
  std::vector<double> along;  // path length from the end, mm
  for (bool pruned = true; pruned;) {
    pruned = false;
    for (const int64_t end : skeleton) {
      if (in[static_cast<size_t>(end)] == 0 || std::popcount(cube_of(end) & ~kCentreBit) != 1)
        continue;
      branch.assign(1, end);
      along.assign(1, 0.0);
      int64_t previous = -1, at = end, junction = -1, widest = end;
      double length = 0.0;
      for (;;) {
        const uint32_t c = cube_of(at) & ~kCentreBit;
        const int n = std::popcount(c);
        if (at != end && n != 2) {  // a junction, or the curve's other end
          if (n >= 3) junction = at;
          break;
        }
        int q = -1;
        for (uint32_t b = c; b != 0; b &= b - 1)
          if (at + offset[static_cast<size_t>(std::countr_zero(b))] != previous) {
            q = std::countr_zero(b);
            break;
          }
        length += step_mm[static_cast<size_t>(q)];
        previous = at;
        at += offset[static_cast<size_t>(q)];
        branch.push_back(at);
        along.push_back(length);
        if (depth[static_cast<size_t>(at)] > depth[static_cast<size_t>(widest)]) widest = at;
      }
      const bool spur = junction >= 0 ? length < kSpurLength * depth[static_cast<size_t>(junction)]
                                      : length <= depth[static_cast<size_t>(widest)];
      if (spur && junction >= 0) {
        branch.pop_back();  // the junction stays
      } else if (spur) {
        branch.erase(std::find(branch.begin(), branch.end(), widest));
      } else {
        // A curve of its own; its end bent off the axis to a flat end's rim goes: from there the
        // radius grows by kBentEndSlope a millimetre in or more (a 3 mm tube's: 1, 1.41, 2, 3 mm
        // over 4.6 mm), where a vessel tapers by far less. The new end is where the radius has
        // grown most beyond that slope (the axis's end).
        const float r0 = depth[static_cast<size_t>(end)];
        size_t keep = 0;
        double most = 0.0;
        for (size_t k = 1; k + 1 < branch.size(); ++k) {
          const float rk = depth[static_cast<size_t>(branch[k])];
          if (along[k] > 2.0 * rk) break;
          const double beyond = rk - r0 - kBentEndSlope * along[k];
          if (beyond >= 0.0 && beyond >= most) {
            most = beyond;
            keep = k;
          }
        }
        if (keep == 0) continue;
        branch.resize(keep);
      }
      for (const int64_t v : branch) in[static_cast<size_t>(v)] = 0;
      pruned = true;
    }
  }

  for (int64_t k = 1; k + 1 < box.n[2]; ++k)
    for (int64_t j = 1; j + 1 < box.n[1]; ++j)
      for (int64_t i = 1; i + 1 < box.n[0]; ++i) {
        const int64_t b = bf.index(i, j, k);
        if (in[static_cast<size_t>(b)] == 0) continue;
        out.voxels.push_back(f.index(i + box.lo[0], j + box.lo[1], k + box.lo[2]));
        out.radius_mm.push_back(depth[static_cast<size_t>(b)]);
      }
  // Ascending linear indices: k, then j, then i outermost to innermost, as visited.
  return out;
}

}  // namespace lamina::geometry
