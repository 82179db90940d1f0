#include "lamina/interact/tools.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <nanoflann.hpp>

#include "lamina/core/error.h"
#include "lamina/interact/contact.h"
#include "skin_samples.h"

namespace lamina::interact {
namespace {

// Moller-Trumbore: distance t > 0 along the unit ray o + t d to triangle (a, b, c), or -1.
double ray_triangle(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& a,
                    const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d e1 = b - a, e2 = c - a;
  const Eigen::Vector3d p = d.cross(e2);
  const double det = e1.dot(p);
  if (std::abs(det) < 1e-14 * e1.squaredNorm()) return -1.0;  // parallel
  const double inv = 1.0 / det;
  const Eigen::Vector3d s = o - a;
  const double u = s.dot(p) * inv;
  if (u < 0.0 || u > 1.0) return -1.0;
  const Eigen::Vector3d q = s.cross(e1);
  const double v = d.dot(q) * inv;
  if (v < 0.0 || u + v > 1.0) return -1.0;
  return e2.dot(q) * inv;
}

// Node v's rings 0..locality-1 as the model stores them (breadth-first, in mesh edges), ring
// by ring.
std::vector<RingMember> rings_by_hops(const Model& model, int32_t v, int32_t locality) {
  std::vector<RingMember> out;
  for (int32_t r = 0; r < locality; ++r)
    for (int64_t k = 0; k < model.rings.ring_size(v, r); ++k)
      out.push_back({model.rings.ring(v, r)[k], r});
  return out;
}

}  // namespace

std::vector<Crossing> force_line_crossings(const Model& model, const Eigen::MatrixX3d& x,
                                           int32_t contact_node, const Eigen::Vector3d& direction) {
  std::vector<Crossing> out{{.layer = model.layer_of.at(static_cast<size_t>(contact_node)),
                             .node = contact_node,
                             .distance_mm = 0.0}};
  const double len = direction.norm();
  if (!(len > 0.0)) return out;
  const Eigen::Vector3d d = direction / len, o = x.row(contact_node).transpose();
  // Hits closer than this to the start are the contact's own triangles.
  const double eps = 1e-6 * (model.X.colwise().maxCoeff() - model.X.colwise().minCoeff()).norm();
  struct Hit {
    double t;
    int32_t layer, node;
  };
  std::vector<Hit> hits;
  for (int32_t k = 0; k < model.layer_count(); ++k) {
    const Eigen::MatrixX3i& F = model.layers[k].F;
    for (Eigen::Index f = 0; f < F.rows(); ++f) {
      const Eigen::Vector3d a = x.row(F(f, 0)), b = x.row(F(f, 1)), c = x.row(F(f, 2));
      const double t = ray_triangle(o, d, a, b, c);
      if (t <= eps) continue;
      // The crossed triangle's vertex nearest to the crossing point receives the copy.
      const Eigen::Vector3d hit = o + t * d;
      int32_t best = F(f, 0);
      for (int j = 1; j < 3; ++j)
        if ((x.row(F(f, j)).transpose() - hit).squaredNorm() <
            (x.row(best).transpose() - hit).squaredNorm())
          best = F(f, j);
      hits.push_back({t, k, best});
    }
  }
  std::sort(hits.begin(), hits.end(), [](const Hit& a, const Hit& b) { return a.t < b.t; });
  for (const Hit& h : hits) {
    // A line through a shared edge or vertex hits two triangles at one point: count it once.
    const Crossing& last = out.back();
    if (last.layer == h.layer && std::abs(h.t - last.distance_mm) <= 1e-9 * (1.0 + h.t)) continue;
    out.push_back({.layer = h.layer, .node = h.node, .distance_mm = h.t});
  }
  return out;
}

std::optional<RoutingProblem> routing_problem(const RoutingOptions& o, int32_t rings_locality) {
  if (o.locality < 1 || o.locality > rings_locality)
    return RoutingProblem{"locality", fmt::format("must be between 1 and the model's rings ({}), "
                                                  "got {}",
                                                  rings_locality, o.locality)};
  if (o.penetration_depth < 1)
    return RoutingProblem{
        "penetration_depth",
        fmt::format("must be at least 1 (the contact itself), got {}", o.penetration_depth)};
  const auto fraction = [](double v) { return v >= 0.0 && v <= 1.0; };  // false for NaN
  if (!fraction(o.ring_attenuation))
    return RoutingProblem{"ring_attenuation",
                          fmt::format("must be between 0 and 1, got {}", o.ring_attenuation)};
  if (!fraction(o.crossing_attenuation))
    return RoutingProblem{"crossing_attenuation",
                          fmt::format("must be between 0 and 1, got {}", o.crossing_attenuation)};
  if (!(o.contact_threshold_mm > 0.0 && std::isfinite(o.contact_threshold_mm)))
    return RoutingProblem{"contact_threshold_mm",
                          fmt::format("must be > 0 mm, got {}", o.contact_threshold_mm)};
  if (!(o.ring_spacing_mm == kPaperRingSpacing ||
        (o.ring_spacing_mm >= 0.0 && std::isfinite(o.ring_spacing_mm))))
    return RoutingProblem{
        "ring_spacing_mm",
        fmt::format("must be >= 0 mm (0: rings in mesh edges) or \"paper\", got {}",
                    o.ring_spacing_mm)};
  return std::nullopt;
}

void check_routing(const RoutingOptions& o, int32_t rings_locality) {
  if (const auto p = routing_problem(o, rings_locality))
    throw invalid_input("solver." + p->key, p->problem);
}

ForceRoute route_force(const Model& model, const Eigen::MatrixX3d& x, int32_t contact_node,
                       const Eigen::Vector3d& force_mn, const RoutingOptions& o) {
  check_routing(o, model.rings.locality);
  ForceRoute route;
  route.contact_node = contact_node;
  route.crossings = force_line_crossings(model, x, contact_node, force_mn);
  if (static_cast<int32_t>(route.crossings.size()) > o.penetration_depth)
    route.crossings.resize(static_cast<size_t>(o.penetration_depth));
  // (node, force) contributions, then merged per node. Each copy is spread over the rings of
  // its node (in mesh edges, or by distance) with weights ring_attenuation^r per node,
  // normalised so that the copy's total is the copy's force: "spreading" moves force around, it
  // does not multiply it.
  const double spacing_mm = resolve_ring_spacing(o, model).ring_spacing_mm;
  std::vector<double> weight(static_cast<size_t>(o.locality));
  double w = 1.0;
  for (double& r : weight) r = w, w *= o.ring_attenuation;
  std::vector<int64_t> count(weight.size());
  std::vector<std::pair<int32_t, Eigen::Vector3d>> parts;
  double copy_scale = 1.0;
  for (const Crossing& c : route.crossings) {
    const std::vector<RingMember> rings =
        spacing_mm > 0.0 ? rings_by_distance(model, c.node, o.locality, spacing_mm)
                         : rings_by_hops(model, c.node, o.locality);
    std::fill(count.begin(), count.end(), 0);
    for (const RingMember& m : rings) ++count[static_cast<size_t>(m.ring)];
    double weight_sum = 0.0;
    for (size_t r = 0; r < weight.size(); ++r)
      weight_sum += weight[r] * static_cast<double>(count[r]);
    for (const RingMember& m : rings)
      parts.emplace_back(
          m.node, (copy_scale * weight[static_cast<size_t>(m.ring)] / weight_sum) * force_mn);
    copy_scale *= o.crossing_attenuation;
  }
  detail::merge_parts(parts, route);
  return route;
}

int32_t most_anterior_skin_node(const Model& model) {
  const ModelLayer& skin = model.layers.at(0);
  Eigen::Index i = 0;
  model.X.col(1).segment(skin.first_node, skin.node_count).minCoeff(&i);
  return skin.first_node + static_cast<int32_t>(i);
}

int32_t nearest_skin_node(const Model& model, const Eigen::MatrixX3d& x,
                          const Eigen::Vector3d& point_mm, double threshold_mm) {
  using Points = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
  const ModelLayer& skin = model.layers.at(0);
  const Points p = x.middleRows(skin.first_node, skin.node_count);
  const nanoflann::KDTreeEigenMatrixAdaptor<Points, 3, nanoflann::metric_L2_Simple> tree(
      3, std::cref(p), 16);
  Eigen::Index index = 0;
  double d2 = 0.0;
  tree.query(point_mm.data(), 1, &index, &d2);
  if (!(std::sqrt(d2) <= threshold_mm)) return -1;
  return skin.first_node + static_cast<int32_t>(index);
}

bool apply_tools(sim::Simulation& s, ToolDriver& d) {
  const Model& m = s.model();
  const size_t n = d.tools.size();
  d.routes.resize(n);
  d.active.resize(n, 0);
  d.grasps.resize(n);
  bool any = false, changed = false;
  for (size_t t = 0; t < n; ++t) {
    const Tool& tool = d.tools[t];
    const bool on = s.time_s >= tool.start_s && s.time_s < tool.end_s;
    if (on && !d.active[t]) {
      // The tool touches down, on the current shape. A push's contact and routing are held from
      // then on; a grasper's jaws close on the skin under them.
      const std::string name = "tools[" + std::to_string(t) + "]";
      if (!tool.by_point && (tool.vertex < 0 || tool.vertex >= m.layers[0].node_count))
        throw invalid_input(name + ".vertex", "must be a skin node, 0.." +
                                                  std::to_string(m.layers[0].node_count - 1) +
                                                  ", got " + std::to_string(tool.vertex));
      if (tool.by_point) {
        const double depth = depth_under_skin(m, s.x, tool.point_mm);
        if (depth > start_depth_limit_mm(tool.radius_mm))
          throw invalid_input(name + ".point",
                              fmt::format("is inside the organ, {:.1f} mm under the skin: a tool "
                                          "starts outside the organ or on its skin",
                                          depth));
      }
      const std::vector<int32_t>* loaded = nullptr;
      if (tool.grasp) {
        const Eigen::Vector3d at =
            tool.by_point ? tool.point_mm : Eigen::Vector3d(s.x.row(tool.vertex).transpose());
        close_jaws(s, {.center_mm = at, .radius_mm = tool.radius_mm}, d.grasps[t], name);
        loaded = &d.grasps[t].nodes;
      } else if (tool.by_point) {
        d.routes[t] =
            load_at_point(m, s.x, tool.point_mm, tool.force_mn, tool.radius_mm, d.routing);
        if (d.routes[t].contact_node < 0)
          throw invalid_input(name + ".point",
                              fmt::format("touches no skin within {} mm (contact_threshold_mm)",
                                          d.routing.contact_threshold_mm));
        loaded = &d.routes[t].nodes;
      } else {
        d.routes[t] = load_at_node(m, s.x, tool.vertex, tool.force_mn, tool.radius_mm, d.routing);
        loaded = &d.routes[t].nodes;
      }
      d.touched.insert(d.touched.end(), loaded->begin(), loaded->end());
      changed = true;
    }
    if (tool.grasp) {
      // The jaws go where the pull puts them at the end of this step; they open at end_s.
      if (on) {
        const double reached =
            std::clamp((s.time_s + s.options().dt_s - tool.start_s) / tool.pull_s, 0.0, 1.0);
        move_jaws(s, d.grasps[t].closed_at_mm + reached * tool.pull_mm, d.grasps[t]);
      } else if (d.active[t]) {
        open_jaws(s, d.grasps[t]);
      }
    }
    if (!on && d.active[t]) changed = true;
    d.active[t] = on;
    any |= on;
  }
  if (d.held_forces.rows() == 0) {
    clear_loads(s, d.loads);
  } else {
    if (d.held_forces.rows() != s.f_ext.rows() || !d.held_forces.allFinite())
      throw invalid_input("held forces", "must be finite, one row per node (" +
                                             std::to_string(s.f_ext.rows()) + "), got " +
                                             std::to_string(d.held_forces.rows()) + " rows");
    s.f_ext = d.held_forces;  // replaces clearing the last step's loads
    d.loads.nodes.clear();
    // Not "cleared": held forces lie on nodes no load lists, so once they are dropped the next
    // clear_loads() zeroes the whole of f_ext (they stayed on for ever when this said cleared).
    d.loads.cleared = false;
  }
  for (size_t t = 0; t < n; ++t)
    if (d.active[t] && !d.tools[t].grasp) add_load(s, d.routes[t], d.loads);
  for (const ForceRoute& r : d.live_routes) add_load(s, r, d.loads);
  add_load(s, d.tip, d.loads);
  if (changed && s.options().mode == sim::Mode::kLocal) keep_touched_movable(s, d.touched);
  return any;
}

void keep_touched_movable(sim::Simulation& s, std::vector<int32_t>& touched) {
  std::sort(touched.begin(), touched.end());
  touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
  if (s.options().mode == sim::Mode::kLocal) sim::set_local_nodes(s, touched);
}

void clear_loads(sim::Simulation& s, Loads& loads) {
  if (!loads.cleared) {
    s.f_ext.setZero();
    loads.cleared = true;
  }
  for (int32_t i : loads.nodes) s.f_ext.row(i).setZero();
  loads.nodes.clear();
}

void add_load(sim::Simulation& s, const ForceRoute& r, Loads& loads) {
  for (size_t k = 0; k < r.nodes.size(); ++k)
    s.f_ext.row(r.nodes[k]) += r.forces.row(static_cast<Eigen::Index>(k));
  loads.nodes.insert(loads.nodes.end(), r.nodes.begin(), r.nodes.end());
}

Eigen::Vector3d reaction_force(const sim::Simulation& s, const Loads& loads) {
  // A node can be loaded by several routes: count it once, in ascending order.
  thread_local std::vector<int32_t> nodes;
  nodes.assign(loads.nodes.begin(), loads.nodes.end());
  std::sort(nodes.begin(), nodes.end());
  nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  // Free nodes that carry a load: what the tissue pushes back with there.
  nodes.erase(std::remove_if(nodes.begin(), nodes.end(),
                             [&](int32_t i) { return s.fixed()[i] || s.f_ext.row(i).isZero(); }),
              nodes.end());
  return sim::internal_force_on(s, nodes);
}

Eigen::Vector3d tools_reaction(const sim::Simulation& s, const ToolDriver& d) {
  Eigen::Vector3d r = reaction_force(s, d.loads);
  for (const Grasp& g : d.grasps) r += grasp_reaction(s, g);
  return r;
}

Eigen::Vector3d live_reaction(const sim::Simulation& s, const ToolDriver& d,
                              const Eigen::Vector3d& device_force_mn) {
  Eigen::Vector3d r = Eigen::Vector3d::Zero();
  if (d.routing.routing == Routing::kNone) {
    for (const ForceRoute& route : d.live_routes) r -= total_force(route);
    r += device_force_mn;
  } else {
    r = reaction_force(s, d.loads);
  }
  if (!d.hand.nodes.empty()) r += grasp_reaction(s, d.hand);
  return r;
}

double last_tool_end(const ToolDriver& d) {
  double end = 0.0;
  for (const Tool& t : d.tools) end = std::max(end, t.end_s);
  return end;
}

}  // namespace lamina::interact
