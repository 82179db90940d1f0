// Which edges of the tetrahedra the blade's swept surface crosses, and where.
#include <algorithm>
#include <cmath>

#include "cut_internal.h"

namespace lamina::model::detail {
namespace {

bool boxes_meet(const Eigen::Vector3d& alo, const Eigen::Vector3d& ahi, const Eigen::Vector3d& blo,
                const Eigen::Vector3d& bhi) {
  return (alo.array() <= bhi.array()).all() && (blo.array() <= ahi.array()).all();
}

}  // namespace

void edge_hits(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const BladeIndex& blade,
               std::vector<double>& hits) {
  const std::vector<BladeTriangle>& tris = blade.tris;
  const double eps = blade.eps;
  hits.clear();
  const Eigen::Vector3d lo = a.cwiseMin(b), hi = a.cwiseMax(b);
  for (const BladeTriangle& t : tris) {
    if (!boxes_meet(lo, hi, t.lo, t.hi)) continue;
    double da = t.n.dot(a - t.p0), db = t.n.dot(b - t.p0);
    if (std::abs(da) <= eps) da = eps;
    if (std::abs(db) <= eps) db = eps;
    if ((da > 0.0) == (db > 0.0)) continue;
    const double f = da / (da - db);
    // q in the triangle's plane up to eps.
    if (in_triangle(t, a + f * (b - a) - t.p0, 1e-12)) hits.push_back(f);
  }
  // A crossing on the edge two blade triangles share is one crossing.
  std::sort(hits.begin(), hits.end());
  hits.erase(std::unique(hits.begin(), hits.end(),
                         [](double p, double q) { return std::abs(p - q) <= 1e-9; }),
             hits.end());
}

BladeIndex index_blade(const Blade& blade) {
  BladeIndex index;
  std::vector<BladeTriangle>& tris = index.tris;
  tris.reserve(static_cast<size_t>(blade.F.rows()));
  Eigen::Vector3d blo = Eigen::Vector3d::Constant(INFINITY), bhi = -blo;
  for (Eigen::Index f = 0; f < blade.F.rows(); ++f) {
    BladeTriangle t;
    t.p0 = blade.V.row(blade.F(f, 0));
    const Eigen::Vector3d p1 = blade.V.row(blade.F(f, 1)), p2 = blade.V.row(blade.F(f, 2));
    t.e1 = p1 - t.p0;
    t.e2 = p2 - t.p0;
    const Eigen::Vector3d n = t.e1.cross(t.e2);
    if (!(n.norm() > 0.0)) continue;  // a degenerate triangle sweeps nothing
    t.n = n.normalized();
    t.lo = t.p0.cwiseMin(p1).cwiseMin(p2);
    t.hi = t.p0.cwiseMax(p1).cwiseMax(p2);
    blo = blo.cwiseMin(t.lo);
    bhi = bhi.cwiseMax(t.hi);
    tris.push_back(t);
  }
  index.lo = blo;
  index.hi = bhi;
  index.eps = 1e-12 * std::max(1.0, (bhi - blo).norm());
  return index;
}

Crossings blade_crossings(const Eigen::MatrixX3d& x, const Eigen::MatrixX4i& T,
                          const BladeIndex& index) {
  const Eigen::Vector3d blo = index.lo, bhi = index.hi;
  Crossings c;
  if (index.tris.empty()) return c;
  std::unordered_map<uint64_t, bool> seen;
  std::vector<double> hits;
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    const Eigen::AlignedBox3d box = tet_box(x, T, t);
    if (!boxes_meet(box.min(), box.max(), blo, bhi)) continue;
    c.near_tets.push_back(static_cast<int32_t>(t));
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) {
        const int32_t a = std::min(T(t, i), T(t, j)), b = std::max(T(t, i), T(t, j));
        if (!seen.emplace(edge_key(a, b), true).second) continue;
        edge_hits(x.row(a).transpose(), x.row(b).transpose(), index, hits);
        if (hits.size() % 2 == 1) c.at.emplace(edge_key(a, b), hits.front());
      }
  }
  return c;
}

}  // namespace lamina::model::detail
