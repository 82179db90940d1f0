// Which structure voxels are the organ's tissue (enclosed_structures.h). Each of the 26 rays is
// followed for all structure voxels at once: a ray from p in direction d is blocked when p + d
// is organ, open when p + d is neither organ nor structure (or beyond the box), and otherwise
// is the ray from p + d. Visiting the voxels so that p + d comes before p (descending linear
// index when d's last non-zero component is positive, ascending otherwise) decides each ray in
// one step. The rules and their measurements: docs/segmentations.md.
#include "lamina/geometry/enclosed_structures.h"

#include <algorithm>
#include <bit>
#include <numeric>

namespace lamina::geometry {
namespace {

enum : uint8_t { kOther = 0, kOrgan = 1, kStructure = 2 };

// A box of the grid with its own x-fastest buffer.
struct Region {
  std::array<int64_t, 3> lo{}, n{};
  int64_t index(int64_t i, int64_t j, int64_t k) const { return (k * n[1] + j) * n[0] + i; }
  int64_t size() const { return n[0] * n[1] * n[2]; }
};

struct Direction {
  int d[3];
  int opposite;  // index of -d among the 26
};

// The 26 neighbour directions, each with its opposite's index.
std::array<Direction, 26> directions() {
  std::array<Direction, 26> out{};
  int n = 0;
  for (int z = -1; z <= 1; ++z)
    for (int y = -1; y <= 1; ++y)
      for (int x = -1; x <= 1; ++x)
        if (x || y || z) out[static_cast<size_t>(n++)] = {{x, y, z}, 0};
  for (int a = 0; a < 26; ++a)
    for (int b = 0; b < 26; ++b)
      if (out[a].d[0] == -out[b].d[0] && out[a].d[1] == -out[b].d[1] && out[a].d[2] == -out[b].d[2])
        out[a].opposite = b;
  return out;
}

// Open rays of every structure voxel: bit r of open[s] is set when ray r from voxel at[s] leaves
// without meeting the organ. `at` is ascending.
std::vector<uint32_t> open_rays(const Region& r, const std::vector<uint8_t>& cls,
                                const std::vector<int64_t>& at,
                                const std::array<Direction, 26>& dirs) {
  const size_t n = at.size();
  std::vector<uint32_t> open(n, 0);
#pragma omp parallel
  {
    // Per thread: the ray's outcome at each structure voxel of the box (read at p + d), and the
    // open bits of its own directions, merged at the end.
    std::vector<uint8_t> blocked(static_cast<size_t>(r.size()), 0);
    std::vector<uint32_t> mine(n, 0);
#pragma omp for schedule(dynamic, 1)
    for (int ray = 0; ray < 26; ++ray) {
      const int* d = dirs[static_cast<size_t>(ray)].d;
      const int64_t step = d[0] + r.n[0] * (d[1] + r.n[1] * d[2]);
      const uint32_t bit = uint32_t{1} << ray;
      const auto visit = [&](size_t s) {
        const int64_t p = at[s];
        const int64_t i = p % r.n[0], j = (p / r.n[0]) % r.n[1], k = p / (r.n[0] * r.n[1]);
        const int64_t ni = i + d[0], nj = j + d[1], nk = k + d[2];
        uint8_t b = 0;
        if (ni >= 0 && nj >= 0 && nk >= 0 && ni < r.n[0] && nj < r.n[1] && nk < r.n[2]) {
          const size_t q = static_cast<size_t>(p + step);
          b = cls[q] == kOrgan ? 1 : (cls[q] == kStructure ? blocked[q] : 0);
        }
        blocked[static_cast<size_t>(p)] = b;
        if (!b) mine[s] |= bit;
      };
      if (step > 0)
        for (size_t s = n; s-- > 0;) visit(s);
      else
        for (size_t s = 0; s < n; ++s) visit(s);
    }
#pragma omp critical
    for (size_t s = 0; s < n; ++s) open[s] |= mine[s];
  }
  return open;
}

// Chebyshev dilation by `radius` voxels, separably: a running maximum along each axis.
void dilate(const Region& r, std::vector<uint8_t>& m, int radius) {
  const int64_t stride[3] = {1, r.n[0], r.n[0] * r.n[1]};
  for (int a = 0; a < 3; ++a) {
    const int b = (a + 1) % 3, c = (a + 2) % 3;
#pragma omp parallel
    {
      std::vector<uint8_t> line(static_cast<size_t>(r.n[a]));
#pragma omp for collapse(2) schedule(static)
      for (int64_t v = 0; v < r.n[c]; ++v)
        for (int64_t u = 0; u < r.n[b]; ++u) {
          int64_t at[3];
          at[a] = 0, at[b] = u, at[c] = v;
          const int64_t base = r.index(at[0], at[1], at[2]);
          for (int64_t t = 0; t < r.n[a]; ++t)
            line[static_cast<size_t>(t)] = m[static_cast<size_t>(base + t * stride[a])];
          for (int64_t t = 0; t < r.n[a]; ++t) {
            uint8_t any = 0;
            for (int64_t s = std::max<int64_t>(0, t - radius);
                 s <= std::min<int64_t>(r.n[a] - 1, t + radius) && !any; ++s)
              any = line[static_cast<size_t>(s)];
            m[static_cast<size_t>(base + t * stride[a])] = any;
          }
        }
    }
  }
}

// The pieces (26-connected, one structure each) of the structures taken whole that touch the
// organ (a 26-neighbour is organ): their voxels' positions in `at`.
std::vector<uint8_t> whole_pieces(const Region& r, const std::vector<uint8_t>& cls,
                                  const std::vector<int64_t>& at, const std::vector<uint8_t>& id,
                                  const std::vector<uint8_t>& whole,
                                  const std::array<Direction, 26>& dirs) {
  const size_t n = at.size();
  std::vector<uint8_t> take(n, 0);
  if (std::none_of(whole.begin(), whole.end(), [](uint8_t w) { return w != 0; })) return take;
  // Union-find over the voxels of whole structures; position of a box voxel by binary search.
  std::vector<int64_t> parent(n);
  std::iota(parent.begin(), parent.end(), int64_t{0});
  const auto find = [&](int64_t a) {
    while (parent[static_cast<size_t>(a)] != a)
      a = parent[static_cast<size_t>(a)] =
          parent[static_cast<size_t>(parent[static_cast<size_t>(a)])];
    return a;
  };
  const auto is_whole = [&](size_t s) {
    return id[s] > 0 && id[s] <= whole.size() && whole[id[s] - 1u] != 0;
  };
  std::vector<uint8_t> touches(n, 0);
  for (size_t s = 0; s < n; ++s) {
    if (!is_whole(s)) continue;
    const int64_t p = at[s];
    const int64_t i = p % r.n[0], j = (p / r.n[0]) % r.n[1], k = p / (r.n[0] * r.n[1]);
    for (const Direction& dir : dirs) {
      const int64_t ni = i + dir.d[0], nj = j + dir.d[1], nk = k + dir.d[2];
      if (ni < 0 || nj < 0 || nk < 0 || ni >= r.n[0] || nj >= r.n[1] || nk >= r.n[2]) continue;
      const int64_t q = r.index(ni, nj, nk);
      const uint8_t c = cls[static_cast<size_t>(q)];
      if (c == kOrgan) touches[s] = 1;
      if (c != kStructure || q < p) continue;  // each pair once
      const size_t t = static_cast<size_t>(std::lower_bound(at.begin(), at.end(), q) - at.begin());
      if (id[t] == id[s])
        parent[static_cast<size_t>(find(static_cast<int64_t>(s)))] = find(static_cast<int64_t>(t));
    }
  }
  std::vector<uint8_t> root_touches(n, 0);
  for (size_t s = 0; s < n; ++s)
    if (is_whole(s) && touches[s])
      root_touches[static_cast<size_t>(find(static_cast<int64_t>(s)))] = 1;
  for (size_t s = 0; s < n; ++s)
    if (is_whole(s)) take[s] = root_touches[static_cast<size_t>(find(static_cast<int64_t>(s)))];
  return take;
}

}  // namespace

EnclosedCounts add_enclosed_structures(const GridFrame& f, std::vector<uint8_t>& organ,
                                       const std::vector<uint8_t>& structures,
                                       int32_t structure_count, const std::vector<uint8_t>& whole,
                                       const std::array<int64_t, 3>& lo,
                                       const std::array<int64_t, 3>& hi) {
  EnclosedCounts out;
  out.added_lo = lo, out.added_hi = hi;
  const size_t ns = static_cast<size_t>(std::max(structure_count, 0));
  out.voxels.assign(ns, 0);
  out.inside.assign(ns, 0);
  out.beside.assign(ns, 0);
  if (ns == 0 || hi[0] < lo[0]) return out;

  // The organ's box widened by the "beside" distance, classified once.
  // A structure taken whole may reach beyond the organ's box (a tumour bulging out of it): the
  // box holds it too.
  std::array<int64_t, 3> box_lo = lo, box_hi = hi;
  if (std::any_of(whole.begin(), whole.end(), [](uint8_t w) { return w != 0; }))
    for (int64_t k = 0; k < f.size[2]; ++k)
      for (int64_t j = 0; j < f.size[1]; ++j)
        for (int64_t i = 0; i < f.size[0]; ++i) {
          const uint8_t s = structures[static_cast<size_t>(f.index(i, j, k))];
          if (s == 0 || s > whole.size() || !whole[s - 1u]) continue;
          box_lo = {std::min(box_lo[0], i), std::min(box_lo[1], j), std::min(box_lo[2], k)};
          box_hi = {std::max(box_hi[0], i), std::max(box_hi[1], j), std::max(box_hi[2], k)};
        }
  Region r;
  for (int a = 0; a < 3; ++a) {
    r.lo[a] = std::max<int64_t>(0, box_lo[a] - kBesideVoxels);
    r.n[a] = std::min<int64_t>(f.size[a] - 1, box_hi[a] + kBesideVoxels) - r.lo[a] + 1;
  }
  std::vector<uint8_t> cls(static_cast<size_t>(r.size()));
#pragma omp parallel for schedule(static)
  for (int64_t k = 0; k < r.n[2]; ++k)
    for (int64_t j = 0; j < r.n[1]; ++j)
      for (int64_t i = 0; i < r.n[0]; ++i) {
        const size_t g = static_cast<size_t>(f.index(r.lo[0] + i, r.lo[1] + j, r.lo[2] + k));
        cls[static_cast<size_t>(r.index(i, j, k))] =
            organ[g] ? kOrgan : (structures[g] ? kStructure : kOther);
      }
  // The structure voxels of the box, ascending, and which structure each is.
  std::vector<int64_t> at;
  std::vector<uint8_t> id;
  for (int64_t k = 0; k < r.n[2]; ++k)
    for (int64_t j = 0; j < r.n[1]; ++j)
      for (int64_t i = 0; i < r.n[0]; ++i) {
        const int64_t p = r.index(i, j, k);
        if (cls[static_cast<size_t>(p)] != kStructure) continue;
        at.push_back(p);
        id.push_back(
            structures[static_cast<size_t>(f.index(r.lo[0] + i, r.lo[1] + j, r.lo[2] + k))]);
      }

  // Each voxel's rules, decided on the classification as it was (so the result does not depend
  // on the order the threads visit them), then made organ.
  // Rounds: what a round takes in is organ for the next, so a tunnel filled along its length
  // closes its mouths too (their line along the tunnel now meets the organ inside), up to the
  // organ's outline, where the lines across the mouth run out both ways. Each round looks only
  // at the voxels still out; a groove, whose line along it runs out both ways, takes none.
  static const std::array<Direction, 26> dirs = directions();
  const std::vector<uint8_t> take = whole_pieces(r, cls, at, id, whole, dirs);
  std::vector<uint8_t> add(cls.size(), 0);  // 1 lines, 2 rays, 3 whole
  for (size_t s = 0; s < at.size(); ++s)
    if (take[s]) add[static_cast<size_t>(at[s])] = 3, cls[static_cast<size_t>(at[s])] = kOrgan;
  std::vector<int64_t> out_voxels;
  for (size_t s = 0; s < at.size(); ++s)
    if (!take[s]) out_voxels.push_back(at[s]);
  for (int round = 0; round < 64 && !out_voxels.empty(); ++round) {
    const std::vector<uint32_t> open = open_rays(r, cls, out_voxels, dirs);
    std::vector<int64_t> still;
    std::vector<int64_t> taken;
    for (size_t s = 0; s < out_voxels.size(); ++s) {
      bool lines = true;
      for (int ray = 0; ray < 26 && lines; ++ray)
        if ((open[s] >> ray & 1u) && (open[s] >> dirs[static_cast<size_t>(ray)].opposite & 1u))
          lines = false;
      const bool rays = std::popcount(open[s]) <= kMaxOpenRays;
      if (lines || rays) {
        add[static_cast<size_t>(out_voxels[s])] = lines ? 1 : 2;
        taken.push_back(out_voxels[s]);
      } else {
        still.push_back(out_voxels[s]);
      }
    }
    if (taken.empty()) break;
    for (const int64_t p : taken) cls[static_cast<size_t>(p)] = kOrgan;
    out_voxels = std::move(still);
  }

  std::vector<uint8_t> near(cls.size());
  std::transform(cls.begin(), cls.end(), near.begin(),
                 [](uint8_t c) { return static_cast<uint8_t>(c == kOrgan); });
  dilate(r, near, kBesideVoxels);

  // Counts over the whole grid (a structure can reach far beyond the organ's box).
  std::vector<int64_t> voxels(ns, 0), inside(ns, 0), beside(ns, 0);
  int64_t own = 0, by[4] = {0, 0, 0, 0};
  for (int64_t k = 0; k < f.size[2]; ++k)
    for (int64_t j = 0; j < f.size[1]; ++j) {
      const int64_t row = f.index(0, j, k);
      const bool row_in =
          k >= r.lo[2] && k < r.lo[2] + r.n[2] && j >= r.lo[1] && j < r.lo[1] + r.n[1];
      for (int64_t i = 0; i < f.size[0]; ++i) {
        const size_t g = static_cast<size_t>(row + i);
        const uint8_t s = structures[g];
        if (s == 0) {
          own += organ[g] != 0;
          continue;
        }
        if (s > ns) continue;  // not a listed structure
        ++voxels[s - 1];
        if (organ[g]) {
          ++inside[s - 1];
          continue;
        }
        if (!row_in || i < r.lo[0] || i >= r.lo[0] + r.n[0]) continue;
        const size_t at_box = static_cast<size_t>(r.index(i - r.lo[0], j - r.lo[1], k - r.lo[2]));
        if (add[at_box]) {
          organ[g] = 1;
          ++inside[s - 1];
          ++by[add[at_box]];
          out.added_lo = {std::min(out.added_lo[0], i), std::min(out.added_lo[1], j),
                          std::min(out.added_lo[2], k)};
          out.added_hi = {std::max(out.added_hi[0], i), std::max(out.added_hi[1], j),
                          std::max(out.added_hi[2], k)};
        } else if (near[at_box]) {
          ++beside[s - 1];
        }
      }
    }
  out.voxels = std::move(voxels);
  out.inside = std::move(inside);
  out.beside = std::move(beside);
  out.organ_own = own;
  out.by_lines = by[1];
  out.by_rays = by[2];
  out.by_whole = by[3];
  out.added = by[1] + by[2] + by[3];
  return out;
}

}  // namespace lamina::geometry
