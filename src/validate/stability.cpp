#include "lamina/validate/stability.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>

#include "lamina/core/error.h"
#include "lamina/geometry/remesh.h"
#include "lamina/interact/tools.h"
#include "lamina/model/summarize_model.h"

namespace lamina::validate {
namespace {

using Clock = std::chrono::steady_clock;

// The layer order (and inverted tetrahedra) at x, folded into the worst at rest or in motion.
void record_layer_order(const Model& m, const Eigen::MatrixX3d& x, bool at_rest,
                        StabilityResult& r) {
  ++r.order_checks;
  const LayerOrder o = check_layer_order(m, x);
  LayerOrder& worst = at_rest ? r.order : r.order_in_motion;
  worst.outside_nodes = std::max(worst.outside_nodes, o.outside_nodes);
  worst.surfaces_cross = worst.surfaces_cross || o.surfaces_cross;
  worst.inverted_tets = std::max(worst.inverted_tets, o.inverted_tets);
}

// One stage: steps until the model has been at rest for o.rest_window_s (or the budget runs out),
// checking each state. After the release it also follows the energy.
struct Stage {
  sim::Simulation& s;
  interact::ToolDriver* tools;  // applied before every step, or nullptr
  const StabilityOptions& o;
  StabilityResult& r;
  double next_check_s = 0.0;
  double release_s = -1.0;  // >= 0: released at this time

  // One step and its checks. False if the state went non-finite.
  bool advance(sim::StepStats& st) {
    if (tools) interact::apply_tools(s, *tools);
    st = sim::step(s);
    ++r.steps;
    if (!s.x.allFinite() || !s.v.allFinite()) {
      r.finite = false;
      return false;
    }
    if (st.unstable != sim::Instability::kNone) {
      r.unstable = st.unstable;
      return false;
    }
    r.peak_displacement_mm = std::max(r.peak_displacement_mm, st.max_displacement_mm);
    r.peak_volume_change_pct = std::max(r.peak_volume_change_pct, std::abs(st.volume_change_pct));
    if (release_s >= 0.0) {
      const double e = st.kinetic_energy_j + sim::elastic_energy(s, s.x);
      r.max_energy_j = std::max(r.max_energy_j, e);
      r.final_energy_j = e;
      r.energy_trace.emplace_back(s.time_s - release_s, e);
    }
    if (s.time_s >= next_check_s) {
      record_layer_order(s.model(), s.x, /*at_rest=*/false, r);
      next_check_s = s.time_s + o.check_interval_s;
    }
    return true;
  }

  // Steps until the model has been at rest for o.rest_window_s. False if it never was (or
  // went non-finite) within the step budget.
  bool run() {
    sim::RestStreak rest{.needed = sim::quiet_steps(s, o.rest_window_s)};
    sim::StepStats st;
    bool rested = false;
    for (int64_t k = 0; k < o.max_steps_per_stage && !rested; ++k) {
      if (!advance(st)) return false;
      rested = rest.update(st);
    }
    record_layer_order(s.model(), s.x, /*at_rest=*/rested, r);
    return rested;
  }

  void release() {
    release_s = s.time_s;
    r.release_energy_j = sim::elastic_energy(s, s.x);  // at rest under the load: no motion
    r.max_energy_j = r.final_energy_j = r.release_energy_j;
    r.energy_trace.emplace_back(0.0, r.release_energy_j);
  }
};

// The skin nodes within the indenter's radius of the contact, outside the held slab.
std::vector<int32_t> indenter_patch(const Model& m, const Indentation& ind,
                                    const std::vector<uint8_t>& held) {
  std::vector<int32_t> patch;
  for (int32_t i = 0; i < m.layers[0].node_count; ++i)
    if (!held[i] && (m.X.row(i).transpose() - ind.contact_mm).norm() <= ind.radius_mm)
      patch.push_back(i);
  if (patch.empty())
    throw invalid_input(m.source, "no skin node within the indenter's radius of the contact");
  return patch;
}

// Up to three tools on the organ's front, all pushing along the indentation direction: the
// indenter's contact, then the most anterior skin nodes a quarter of the organ's width to its
// left and to its right (a probe and two graspers' worth of load at once). The paper's routing
// (its rings by distance) adds its copies (rings, crossings) without normalising them, so each
// tool's force is scaled for its routed load along `dir` to total `force_n`.
std::vector<interact::Tool> make_tools(const Model& m, const Indentation& ind, int32_t count,
                                       double force_n, const interact::RoutingOptions& routing) {
  const int32_t skin = m.layers[0].node_count;
  const Eigen::VectorXd xs = m.X.col(0).head(skin);
  const double width = xs.maxCoeff() - xs.minCoeff();
  const Eigen::Vector3d dir = ind.direction.normalized();
  auto front_near = [&](double x) {  // the skin node most against `dir` within a strip at x
    int32_t best = -1;
    for (int32_t i = 0; i < skin; ++i)
      if (std::abs(m.X(i, 0) - x) <= 0.05 * width &&
          (best < 0 || m.X.row(i).dot(dir) < m.X.row(best).dot(dir)))
        best = i;
    return best;
  };
  const int32_t front =
      interact::nearest_skin_node(m, m.X, ind.contact_mm, std::numeric_limits<double>::infinity());
  std::vector<int32_t> contacts = {front};
  if (count >= 2) contacts.push_back(front_near(m.X(front, 0) - 0.25 * width));
  if (count >= 3) contacts.push_back(front_near(m.X(front, 0) + 0.25 * width));
  std::vector<interact::Tool> tools;
  for (int32_t node : contacts) {
    if (node < 0) continue;  // no skin there (the contact is near the organ's side)
    const interact::ForceRoute route =
        interact::load_at_node(m, m.X, node, dir, interact::kDefaultPatchRadiusMm, routing);
    const double total = (route.forces * dir).sum();  // mN per mN of tool force
    interact::Tool t;
    t.vertex = node;
    t.force_mn = 1000.0 * force_n / std::max(total, 1e-12) * dir;
    tools.push_back(t);
  }
  return tools;
}

}  // namespace

LayerOrder check_layer_order(const Model& m, const Eigen::MatrixX3d& x) {
  LayerOrder order;
  SurfaceMesh outer = model::layer_mesh(m, 0, x);
  for (int32_t l = 1; l < m.layer_count(); ++l) {
    SurfaceMesh inner = model::layer_mesh(m, l, x);
    const geometry::Nesting n = geometry::check_nesting(outer, inner);
    order.outside_nodes += n.vertices_outside;
    order.surfaces_cross = order.surfaces_cross || n.surfaces_intersect;
    outer = std::move(inner);
  }
  order.inverted_tets = sim::inverted_tets(m, x);
  return order;
}

double StabilityResult::energy_rise() const {
  return release_energy_j > 0.0 ? max_energy_j / release_energy_j - 1.0 : 0.0;
}

bool StabilityResult::energy_decays(const StabilityOptions& o) const {
  return max_energy_j <= release_energy_j * (1.0 + o.energy_rise_tolerance) &&
         final_energy_j <= release_energy_j * o.final_energy_fraction;
}

// The one list of the checks: a case passes when it missed none of them.
bool StabilityResult::passed(const StabilityOptions& o) const {
  return failure(o).empty();
}

std::string StabilityResult::failure(const StabilityOptions& o) const {
  std::vector<std::string> why;
  if (!finite) why.push_back("a state went non-finite");
  if (unstable != sim::Instability::kNone)
    why.push_back(fmt::format("unstable at step {} ({})", steps, sim::describe(unstable)));
  if (order.outside_nodes > 0)
    why.push_back(fmt::format("{} inner node{} outside their layer at rest", order.outside_nodes,
                              order.outside_nodes == 1 ? "" : "s"));
  if (order.surfaces_cross) why.push_back("layers cross at rest");
  if (order.inverted_tets > 0)
    why.push_back(fmt::format("{} {} inverted at rest", order.inverted_tets,
                              order.inverted_tets == 1 ? "tetrahedron" : "tetrahedra"));
  // A stage cut short by instability never came to rest: said once, above.
  if (finite && unstable == sim::Instability::kNone) {
    if (!loaded_at_rest)
      why.push_back(fmt::format("no rest under the load in {} steps", o.max_steps_per_stage));
    else if (!returned_at_rest)
      why.push_back(fmt::format("no rest after the release in {} steps", o.max_steps_per_stage));
  }
  if (loaded_at_rest && !energy_decays(o))
    why.push_back(fmt::format("the energy after the release rose {:.1f}% / ended at {:.2g} of it",
                              100.0 * energy_rise(),
                              release_energy_j > 0.0 ? final_energy_j / release_energy_j : 0.0));
  if (rest_error_mm > o.rest_tolerance_mm)
    why.push_back(fmt::format("{:.3g} mm from rest at the end (tolerance {:g} mm)", rest_error_mm,
                              o.rest_tolerance_mm));
  return fmt::format("{}", fmt::join(why, "; "));
}

std::vector<StabilityCase> stability_cases(double dt, bool quick, bool projective) {
  using sim::Integrator;
  std::vector<StabilityCase> cases;
  auto indent = [&](LoadKind kind, double pct, Integrator in, double h) {
    cases.push_back({fmt::format("{} {:.0f}%", kind == LoadKind::kIndent ? "indent" : "pull", pct),
                     kind, pct / 100.0, 0, 0.0, in, h});
  };
  auto tools = [&](int32_t n, double force_n) {
    cases.push_back({fmt::format("{} tool{} {:g} N", n, n > 1 ? "s" : "", force_n),
                     LoadKind::kTools, 0.0, n, force_n, Integrator::kImplicitEuler, dt});
  };
  if (quick) {
    indent(LoadKind::kIndent, 50, Integrator::kImplicitEuler, dt);
    indent(LoadKind::kPull, 30, Integrator::kImplicitEuler, dt);
    tools(3, 1.0);
    indent(LoadKind::kIndent, 30, Integrator::kImplicitEuler, 10 * dt);
    if (projective)
      indent(LoadKind::kIndent, 30, Integrator::kProjective, 10 * dt);
    else
      indent(LoadKind::kIndent, 30, Integrator::kSemiImplicitEuler, 0.1 * dt);
    return cases;
  }
  for (double pct : {10.0, 20.0, 30.0, 40.0, 50.0})
    indent(LoadKind::kIndent, pct, Integrator::kImplicitEuler, dt);
  for (double pct : {10.0, 20.0, 30.0})
    indent(LoadKind::kPull, pct, Integrator::kImplicitEuler, dt);
  for (int32_t n : {1, 2, 3}) tools(n, 1.0);
  for (Integrator in :
       {Integrator::kSemiImplicitEuler, Integrator::kImplicitEuler, Integrator::kProjective}) {
    if (in == Integrator::kProjective && !projective) continue;
    for (double f : {0.1, 0.3, 1.0, 3.0, 10.0})
      if (in != Integrator::kImplicitEuler || f != 1.0)  // that one is the 30% load case
        indent(LoadKind::kIndent, 30, in, f * dt);
  }
  return cases;
}

StabilityResult run_stability_case(const Model& m, const sim::Material& material,
                                   const sim::SolverOptions& solver, const Indentation& ind,
                                   const StabilityCase& c, const StabilityOptions& o,
                                   const model::SurfaceSupport& support) {
  const auto t0 = Clock::now();
  sim::Material mat = material;
  mat.gravity_mm_per_s2.setZero();
  sim::SolverOptions opt = solver;
  opt.mode = sim::Mode::kGlobal;
  opt.integrator = c.integrator;
  opt.dt_s = c.dt_s;
  opt.rest_speed_mm_per_s = o.rest_speed_mm_per_s;
  sim::Simulation s = sim::make_simulation(m, mat, opt);
  const std::vector<int32_t> held =
      sim::nodes_near_plane(m, ind.held_point_mm, ind.held_normal, ind.held_distance_mm);
  sim::fix_nodes(s, held);
  sim::support_nodes(s, support.nodes, support.stiffness_n_per_m);

  StabilityResult r;
  r.c = c;
  Stage stage{s, nullptr, o, r};
  bool loaded = true;
  std::vector<int32_t> patch;
  interact::ToolDriver driver;
  if (c.kind == LoadKind::kTools) {
    driver.routing.locality = std::min(driver.routing.locality, m.rings.locality);
    // The rings in millimetres, as far apart as on the organ's paper-size skin: the case is the
    // same load on the same area at every mesh size (hop rings shrink with the edge).
    driver.routing.ring_spacing_mm = interact::paper_ring_spacing_mm(m);
    driver.tools = make_tools(m, ind, c.tool_count, c.tool_force_n, driver.routing);
    stage.tools = &driver;
    loaded = stage.run();
  } else {
    patch = indenter_patch(m, ind, s.fixed());
    const double sign = c.kind == LoadKind::kPull ? -1.0 : 1.0;
    const Eigen::RowVector3d step =
        sign * c.depth_fraction * ind.organ_depth_mm * ind.direction.normalized().transpose();
    // The indenter moves at a steady speed over ramp_s (a step's jump of the patch would kick its
    // neighbours, an artefact of the test, not of the tissue), then holds until rest.
    Eigen::MatrixX3d at(static_cast<Eigen::Index>(patch.size()), 3);
    const double start = s.time_s;
    sim::StepStats st;
    for (double f = 0.0; f < 1.0 && r.finite;) {
      f = std::min(1.0, (s.time_s + c.dt_s - start) / o.ramp_s);  // where it is at the step's end
      for (size_t q = 0; q < patch.size(); ++q)
        at.row(static_cast<Eigen::Index>(q)) = m.X.row(patch[q]) + f * step;
      sim::hold_nodes(s, patch, at);
      stage.advance(st);
    }
    loaded = r.finite && stage.run();
  }
  r.loaded_at_rest = loaded && r.finite;
  if (r.finite) {
    if (c.kind == LoadKind::kTools) {
      for (interact::Tool& t : driver.tools) t.end_s = s.time_s;
      interact::apply_tools(s, driver);
    } else {
      sim::release_nodes(s, patch);
    }
    stage.release();
    r.returned_at_rest = stage.run() && r.finite;
  }
  r.recoveries = s.recoveries;
  r.rest_error_mm = r.finite ? (s.x - m.X).rowwise().norm().maxCoeff() : INFINITY;
  r.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return r;
}

}  // namespace lamina::validate
