#include "lamina/interact/haptic_proxy.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "lamina/geometry/closest_on_triangle.h"
#include "lamina/interact/contact.h"
#include "skin_samples.h"

namespace lamina::interact {
namespace {

struct Near {
  SkinPoint at;
  Eigen::Vector3d outward = Eigen::Vector3d::Zero();  // the nearest triangle's unit normal
};

// The surface's point nearest to p among the gathered triangles `close` lists: a triangle whose
// box is farther than the best so far is skipped before its closest point is solved. (Starting
// from the last answer's triangle was tried: slower, 58 us against 47 us a step on the
// phantom's display skin, sim_bench BM_ToolTipOnDisplaySkin.)
Near nearest_of(const detail::Gathered& g, const std::vector<uint32_t>& close,
                const Eigen::Vector3d& p) {
  Near best;
  for (const uint32_t k : close) {
    if (best.at.face >= 0 && g.out_of_reach(k, p, best.at.distance_mm)) continue;
    const Eigen::Vector3d w = geometry::closest_on_triangle(p, g.a[k], g.b[k], g.c[k]);
    const Eigen::Vector3d q = w[0] * g.a[k] + w[1] * g.b[k] + w[2] * g.c[k];
    const double d = (q - p).norm();
    if (d < best.at.distance_mm) {
      best.at = {.face = g.face[k], .barycentric = w, .point_mm = q, .distance_mm = d};
      best.outward = (g.b[k] - g.a[k]).cross(g.c[k] - g.a[k]).normalized();
    }
  }
  return best;
}

// Forgets the proxy (placed afresh next time), keeping its neighbour list and its buffers.
void lift(HapticProxy& s) {
  SkinNeighbourhood near = std::move(s.near);
  Eigen::MatrixX3d surface = std::move(s.surface_mm);
  s = {};
  s.near = std::move(near);
  s.surface_mm = std::move(surface);
}

// Pushes p out of the surface to the radius r: along p - q from the nearest point q when p is on
// the outer side of q's triangle, along the triangle's outward normal when p has gone past it.
// A few passes settle it in a concave corner, where leaving one triangle enters another.
void project_out(const detail::Gathered& g, const std::vector<uint32_t>& close, double r,
                 Eigen::Vector3d& p) {
  for (int pass = 0; pass < 4; ++pass) {
    const Near n = nearest_of(g, close, p);
    if (n.at.face < 0 || n.at.distance_mm >= r) return;
    const Eigen::Vector3d away = p - n.at.point_mm;
    const bool outside = away.dot(n.outward) > 0.0 && n.at.distance_mm > 1e-9 * r;
    p = n.at.point_mm + r * (outside ? Eigen::Vector3d(away / n.at.distance_mm) : n.outward);
  }
}

}  // namespace

std::optional<RoutingProblem> tip_problem(const ToolTip& t) {
  const auto positive = [](double v) { return v > 0.0 && std::isfinite(v); };
  if (!positive(t.radius_mm)) return RoutingProblem{"radius_mm", "must be > 0 mm"};
  if (!(t.stiffness_n_per_m >= 0.0 && std::isfinite(t.stiffness_n_per_m)))
    return RoutingProblem{"stiffness_n_per_m", "must be >= 0 N/m"};
  if (!positive(t.max_force_n))
    return RoutingProblem{"max_force_n", "must be > 0 N (the most a device is sent)"};
  if (!positive(t.max_force_change_n))
    return RoutingProblem{"max_force_change_n", "must be > 0 N a step"};
  if (!t.center_mm.allFinite()) return RoutingProblem{"center_mm", "is not finite"};
  return std::nullopt;
}

ForceRoute couple_proxy(const Model& m, const Eigen::MatrixX3d& x, const ToolTip& tip,
                        HapticProxy& s, Touch touch) {
  if (!tip.active || m.layers.empty()) {
    lift(s);
    return {};
  }
  const detail::SurfaceView surface = detail::touch_view(m, x, touch);
  const double r = tip.radius_mm;
  const Eigen::Vector3d& device = tip.center_mm;
  if (!s.placed) {
    // Placed only from outside: from inside, the nearest surface may be the far side's.
    if (s.started_inside && --s.recheck_in > 0) return {};
    const double depth = detail::depth_under(surface, device, s.surface_mm);
    if (depth > start_depth_limit_mm(r)) {
      lift(s);
      s.started_inside = true;
      s.start_depth_mm = depth;
      s.recheck_in = kInsideRecheckSteps;
      return {};
    }
    s.started_inside = false;
    s.start_depth_mm = 0.0;
  }
  const Eigen::Vector3d start = s.placed ? s.proxy_mm : device;

  // The surface's triangles the proxy can meet on its way: it moves within the ball around the
  // segment from where it was to the device, and a projection moves it by up to r more. The
  // load's patch reaches r beyond the proxy's contact (within r of the proxy, which a
  // projection may carry r past that ball): the neighbour list covers both, and the
  // proxy's own moves look only at the triangles within their reach.
  const Eigen::Vector3d mid = 0.5 * (start + device);
  const double reach = 2.0 * r + 0.5 * (device - start).norm();
  detail::faces_near(surface, mid, reach + 2.0 * r, s.near);  // s.near lists them
  // Gathered once a step: the load's patch (reach + 2r) and, listed in `close`, the moves'.
  thread_local detail::Gathered near;
  thread_local std::vector<uint32_t> close;
  thread_local std::vector<Eigen::Vector3d> vertices;
  near.gather_listed(surface, s.near, mid, reach + 2.0 * r, vertices);
  close.clear();
  for (size_t k = 0; k < near.size(); ++k)
    if (!near.out_of_reach(k, mid, reach)) close.push_back(static_cast<uint32_t>(k));

  // The god-object: from where it was, towards the device in moves of at most r/4, each
  // projected out of the surface, so that it slides over it to the point nearest the device and
  // never crosses to the other side.
  Eigen::Vector3d p = start;
  project_out(near, close, r, p);  // the surface may have moved into it (or the device starts in)
  const int moves =
      std::clamp(static_cast<int>(std::ceil((device - p).norm() / (0.25 * r))), 1, 64);
  for (int k = 0; k < moves; ++k) {
    Eigen::Vector3d move = device - p;
    if (move.norm() > 0.25 * r) move *= 0.25 * r / move.norm();
    p += move;
    project_out(near, close, r, p);
  }
  s.placed = true;
  s.proxy_mm = p;

  // The coupling: on the device k (proxy - device), bounded, and changing by a bounded step.
  const double most = 1000.0 * tip.max_force_n, step = 1000.0 * tip.max_force_change_n;
  Eigen::Vector3d f = tip.stiffness_n_per_m * (p - device);
  if (f.norm() > most) f *= most / f.norm();
  Eigen::Vector3d change = f - s.device_force_mn;
  if (change.norm() > step) change *= step / change.norm();
  s.device_force_mn += change;

  // The tissue takes exactly minus the device's force where the proxy rests on it.
  const Near n = nearest_of(near, close, p);
  s.touching = n.at.face >= 0 && n.at.distance_mm <= r * (1.0 + 1e-6);
  if (!s.touching || s.device_force_mn.isZero()) return {};
  return detail::spread_on_gathered(surface, near, n.at, -s.device_force_mn, r);
}

}  // namespace lamina::interact
