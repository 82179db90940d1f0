#include <algorithm>
#include <cstdint>
#include <vector>

#include "lamina/interact/contact.h"
#include "skin_samples.h"

namespace lamina::interact {
namespace {

// Scalar shares per node, summed in place (a dense array over the nodes, reset after use) rather
// than sorted and merged: a display skin hands each sample to 12 nodes.
struct Shares {
  std::vector<double> share;
  std::vector<uint8_t> seen;
  std::vector<int32_t> nodes;  // those with a share, in first-touch order

  void add(int32_t node, double w) {
    const auto n = static_cast<size_t>(node);
    if (!seen[n]) seen[n] = 1, nodes.push_back(node);
    share[n] += w;
  }
  void clear() {
    for (const int32_t n : nodes)
      share[static_cast<size_t>(n)] = 0.0, seen[static_cast<size_t>(n)] = 0;
    nodes.clear();
  }
};

}  // namespace

ForceRoute spread_on_patch(const Model& m, const Eigen::MatrixX3d& x, const SkinPoint& at,
                           const Eigen::Vector3d& force_mn, double radius_mm) {
  return detail::spread_on_surface(detail::skin_view(m, x), at, force_mn, radius_mm);
}

ForceRoute detail::spread_on_surface(const SurfaceView& s, const SkinPoint& at,
                                     const Eigen::Vector3d& force_mn, double radius_mm) {
  if (at.face < 0) return {};
  thread_local Gathered g;
  g.gather(s, nullptr, at.point_mm, std::max(radius_mm, 0.0));
  return spread_on_gathered(s, g, at, force_mn, radius_mm);
}

ForceRoute detail::spread_on_gathered(const SurfaceView& s, const Gathered& g, const SkinPoint& at,
                                      const Eigen::Vector3d& force_mn, double radius_mm) {
  ForceRoute route;
  if (at.face < 0) return route;
  const Eigen::MatrixX3i& F = s.F;
  int best = 0;
  at.barycentric.maxCoeff(&best);
  route.contact_node = s.marker_node(F(at.face, best));

  // Weights w = pressure x area per sample; each passes w times its barycentric weights on (and,
  // on a carried surface, those times the embedding's weights).
  thread_local Shares shares;
  shares.share.resize(static_cast<size_t>(s.x.rows()), 0.0);  // zero between calls
  shares.seen.resize(static_cast<size_t>(s.x.rows()), 0);
  const auto add = [&](int32_t node, double w) { shares.add(node, w); };
  double total = 0.0;
  if (radius_mm > 0.0) {
    const Eigen::Vector3d facing = s.vertex(F(at.face, 1)) - s.vertex(F(at.face, 0));
    const Eigen::Vector3d normal = facing.cross(s.vertex(F(at.face, 2)) - s.vertex(F(at.face, 0)));
    const double r2 = radius_mm * radius_mm;
    const auto cuts = [&](int32_t, const Eigen::Vector3d&, double, double longest) {
      return detail::cuts_for(longest, radius_mm / 3.0);
    };
    const auto visit = [&](int32_t f, const Eigen::Vector3d& bary, const Eigen::Vector3d& y,
                           double area) {
      const double q = 1.0 - (y - at.point_mm).squaredNorm() / r2;
      if (q <= 0.0) return;
      const double w = q * area;
      total += w;
      for (int c = 0; c < 3; ++c)
        if (bary[c] != 0.0) s.to_nodes(F(f, c), w * bary[c], add);
    };
    for (size_t k = 0; k < g.size(); ++k)
      if (!g.out_of_reach(k, at.point_mm, radius_mm) &&
          (g.b[k] - g.a[k]).cross(g.c[k] - g.a[k]).dot(normal) > 0.0)
        detail::sample_triangle(g.face[k], g.a[k], g.b[k], g.c[k], at.point_mm, radius_mm, cuts,
                                visit);
  }
  if (!(total > 0.0)) {  // a point load: the contact point's own triangle
    shares.clear();
    for (int c = 0; c < 3; ++c)
      if (at.barycentric[c] != 0.0) s.to_nodes(F(at.face, c), at.barycentric[c], add);
    total = at.barycentric.sum();
  }
  std::sort(shares.nodes.begin(), shares.nodes.end());
  route.nodes = shares.nodes;
  route.forces.resize(static_cast<Eigen::Index>(route.nodes.size()), 3);
  for (size_t j = 0; j < route.nodes.size(); ++j)
    route.forces.row(static_cast<Eigen::Index>(j)) =
        (shares.share[static_cast<size_t>(route.nodes[j])] / total) * force_mn.transpose();
  shares.clear();  // for the next call
  return route;
}

}  // namespace lamina::interact
