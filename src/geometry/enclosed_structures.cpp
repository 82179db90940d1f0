// Which structure voxels the organ encloses: 13 lines through each, marched voxel by voxel in
// the grid's own index steps (a line is the 26-neighbour direction and its opposite). Lines,
// not a share of rays: a tumour that reaches the organ's surface, or a vessel's tunnel at the
// hilum, has half its rays leave through the opening, yet every line through it meets the
// organ on one side; a vessel outside the organ has the line along it (or a tangent one) open
// both ways. Measured on the carved-out phantom (docs/architecture.md, "Carved-out labels").
#include "lamina/geometry/enclosed_structures.h"

#include <algorithm>

namespace lamina::geometry {
namespace {

// The 13 directions whose first non-zero component is positive; each with its opposite spans
// the 26 neighbours.
constexpr int kLines[13][3] = {{1, 0, 0},  {0, 1, 0},  {0, 0, 1},  {1, 1, 0},  {1, -1, 0},
                               {1, 0, 1},  {1, 0, -1}, {0, 1, 1},  {0, 1, -1}, {1, 1, 1},
                               {1, 1, -1}, {1, -1, 1}, {1, -1, -1}};

enum : uint8_t { kOther = 0, kOrgan = 1, kStructure = 2 };

// A box of the grid with its own x-fastest buffer.
struct Region {
  std::array<int64_t, 3> lo{}, n{};
  int64_t index(int64_t i, int64_t j, int64_t k) const { return (k * n[1] + j) * n[0] + i; }
  int64_t size() const { return n[0] * n[1] * n[2]; }
};

// Whether a ray from region voxel (i, j, k) in direction d meets the organ before anything
// that is neither organ nor structure, or the region's edge.
bool hits(const Region& r, const std::vector<uint8_t>& cls, int64_t i, int64_t j, int64_t k, int dx,
          int dy, int dz) {
  for (;;) {
    i += dx, j += dy, k += dz;
    if (i < 0 || j < 0 || k < 0 || i >= r.n[0] || j >= r.n[1] || k >= r.n[2]) return false;
    const uint8_t c = cls[static_cast<size_t>(r.index(i, j, k))];
    if (c != kStructure) return c == kOrgan;
  }
}

bool enclosed(const Region& r, const std::vector<uint8_t>& cls, int64_t i, int64_t j, int64_t k) {
  for (const auto& d : kLines)
    if (!hits(r, cls, i, j, k, d[0], d[1], d[2]) && !hits(r, cls, i, j, k, -d[0], -d[1], -d[2]))
      return false;
  return true;
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

}  // namespace

EnclosedCounts add_enclosed_structures(const GridFrame& f, std::vector<uint8_t>& organ,
                                       const std::vector<uint8_t>& structures,
                                       int32_t structure_count, const std::array<int64_t, 3>& lo,
                                       const std::array<int64_t, 3>& hi) {
  EnclosedCounts out;
  const size_t ns = static_cast<size_t>(std::max(structure_count, 0));
  out.voxels.assign(ns, 0);
  out.inside.assign(ns, 0);
  out.beside.assign(ns, 0);
  if (ns == 0 || hi[0] < lo[0]) return out;

  // The organ's box widened by the "beside" distance, classified once.
  Region r;
  for (int a = 0; a < 3; ++a) {
    r.lo[a] = std::max<int64_t>(0, lo[a] - kBesideVoxels);
    r.n[a] = std::min<int64_t>(f.size[a] - 1, hi[a] + kBesideVoxels) - r.lo[a] + 1;
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

  // Enclosed voxels, decided on the classification as it was (so the result does not depend on
  // the order the threads visit them), then made organ.
  std::vector<uint8_t> add(cls.size(), 0);
#pragma omp parallel for schedule(dynamic, 1)
  for (int64_t k = 0; k < r.n[2]; ++k)
    for (int64_t j = 0; j < r.n[1]; ++j)
      for (int64_t i = 0; i < r.n[0]; ++i) {
        const size_t at = static_cast<size_t>(r.index(i, j, k));
        if (cls[at] == kStructure && enclosed(r, cls, i, j, k)) add[at] = 1;
      }

  std::vector<uint8_t> near(cls.size());
  std::transform(cls.begin(), cls.end(), near.begin(),
                 [](uint8_t c) { return static_cast<uint8_t>(c == kOrgan); });
  dilate(r, near, kBesideVoxels);

  // Counts over the whole grid (a structure can reach far beyond the organ's box).
  std::vector<int64_t> voxels(ns, 0), inside(ns, 0), beside(ns, 0);
  int64_t own = 0, added = 0;
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
        const size_t at = static_cast<size_t>(r.index(i - r.lo[0], j - r.lo[1], k - r.lo[2]));
        if (add[at]) {
          organ[g] = 1;
          ++inside[s - 1];
          ++added;
        } else if (near[at]) {
          ++beside[s - 1];
        }
      }
    }
  out.voxels = std::move(voxels);
  out.inside = std::move(inside);
  out.beside = std::move(beside);
  out.organ_own = own;
  out.added = added;
  return out;
}

}  // namespace lamina::geometry
