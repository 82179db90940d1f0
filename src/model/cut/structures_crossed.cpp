// Where the blade crosses the embedded structures: each vessel cut across, its place and its
// local diameter (from the area of its cross-section in the blade).
#include <cmath>
#include <numbers>
#include <numeric>

#include "cut_internal.h"
#include "lamina/model/embed_surface.h"

namespace lamina::model::detail {
namespace {

// The loops of one surface's crossing: the crossed edges, joined through the triangles that
// have two of them.
void loops_of(const EmbeddedSurface& s, const Eigen::MatrixX3d& p, const BladeIndex& blade,
              const Eigen::Vector3d& near_lo, const Eigen::Vector3d& near_hi,
              std::vector<StructureCut>& out) {
  const Eigen::Vector3d box_lo = blade.lo.cwiseMax(near_lo), box_hi = blade.hi.cwiseMin(near_hi);
  std::unordered_map<uint64_t, int32_t> crossed;  // edge -> its point
  std::vector<Eigen::Vector3d> point;
  std::vector<std::array<int32_t, 2>> segment;
  std::vector<double> hits;
  for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
    Eigen::Vector3d lo = p.row(s.F(f, 0)), hi = lo;
    for (int k = 1; k < 3; ++k) {
      lo = lo.cwiseMin(p.row(s.F(f, k)).transpose());
      hi = hi.cwiseMax(p.row(s.F(f, k)).transpose());
    }
    if ((lo.array() > box_hi.array()).any() || (hi.array() < box_lo.array()).any()) continue;
    int32_t ends[3];
    int n = 0;
    for (int k = 0; k < 3; ++k) {
      const int32_t a = s.F(f, k), b = s.F(f, (k + 1) % 3);
      const uint64_t key = edge_key(a, b);
      auto it = crossed.find(key);
      if (it == crossed.end()) {
        const int32_t lo_v = std::min(a, b), hi_v = std::max(a, b);
        edge_hits(p.row(lo_v).transpose(), p.row(hi_v).transpose(), blade, hits);
        int32_t at = -1;
        if (hits.size() % 2 == 1) {
          at = static_cast<int32_t>(point.size());
          point.push_back(p.row(lo_v).transpose() +
                          hits.front() * (p.row(hi_v) - p.row(lo_v)).transpose());
        }
        it = crossed.emplace(key, at).first;
      }
      if (it->second >= 0) ends[n++] = it->second;
    }
    if (n == 2) segment.push_back({ends[0], ends[1]});
  }
  if (segment.empty()) return;
  // A loop is closed when each of its points ends two segments.
  std::vector<int32_t> degree(point.size(), 0);
  for (const auto& [a, b] : segment) ++degree[a], ++degree[b];
  std::vector<int32_t> parent(point.size());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int32_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  for (const auto& [a, b] : segment) parent[find(a)] = find(b);
  std::unordered_map<int32_t, size_t> loop;
  std::vector<Eigen::Vector3d> centre;
  std::vector<int32_t> count;
  std::vector<uint8_t> closed;
  for (int32_t k = 0; k < static_cast<int32_t>(point.size()); ++k) {
    auto [it, fresh] = loop.try_emplace(find(k), centre.size());
    if (fresh)
      centre.emplace_back(Eigen::Vector3d::Zero()), count.push_back(0), closed.push_back(1);
    if (degree[k] != 2) closed[it->second] = 0;
    centre[it->second] += point[k];
    ++count[it->second];
  }
  for (size_t l = 0; l < centre.size(); ++l) centre[l] /= count[l];
  // The area a loop encloses, as triangles from its centre (a vessel's section is near convex).
  std::vector<double> area(centre.size(), 0.0);
  for (const auto& [a, b] : segment) {
    const size_t l = loop[find(a)];
    area[l] += 0.5 * (point[a] - centre[l]).cross(point[b] - centre[l]).norm();
  }
  for (size_t l = 0; l < centre.size(); ++l) {
    if (count[l] < 3) continue;  // a graze across one edge or two: no section
    out.push_back({.name = s.name,
                   .role = s.role,
                   .label = s.label,
                   .position_mm = centre[l],
                   .area_mm2 = area[l],
                   .diameter_mm = 2.0 * std::sqrt(area[l] / std::numbers::pi),
                   .closed = closed[l] != 0});
  }
}

}  // namespace

std::vector<StructureCut> structures_crossed(const Model& model, const Eigen::MatrixX3d& x,
                                             const BladeIndex& blade,
                                             const Eigen::Vector3d& near_lo,
                                             const Eigen::Vector3d& near_hi) {
  std::vector<StructureCut> out;
  if (blade.tris.empty()) return out;
  Eigen::MatrixX3d p;
  for (const EmbeddedSurface& s : model.embedded) {
    if (!is_anatomy(s.role)) continue;  // the display skin, the wound: the organ itself
    embedded_positions(s, x, p);
    loops_of(s, p, blade, near_lo, near_hi, out);
  }
  return out;
}

}  // namespace lamina::model::detail

namespace lamina::model {

std::vector<StructureCut> structures_crossed(const Model& model, const Eigen::MatrixX3d& x,
                                             const Blade& blade, const Eigen::Vector3d& near_lo,
                                             const Eigen::Vector3d& near_hi) {
  return detail::structures_crossed(model, x, detail::index_blade(blade), near_lo, near_hi);
}

}  // namespace lamina::model
