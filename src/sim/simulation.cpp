// Setting a simulation up and changing what it holds: parameters, fixed, held, supported and
// local nodes, resets and checkpoints. Every change of which nodes move goes through refresh(),
// which rebuilds the lists a step visits and what the measurements cache about the rest.
#include "lamina/sim/simulation.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "lamina/core/error.h"
#include "lamina/sim/contact_springs.h"
#include "solver.h"

namespace lamina::sim {

using namespace detail;

Simulation::Simulation() : solver_(std::make_unique<Solver>()) {}
Simulation::~Simulation() = default;
Simulation::Simulation(const Simulation& o)
    : x(o.x),
      v(o.v),
      f_ext(o.f_ext),
      time_s(o.time_s),
      steps(o.steps),
      recoveries(o.recoveries),
      solver_(std::make_unique<Solver>(*o.solver_)) {
  // A factor or a hierarchy is rebuilt on first use rather than shared with its workspace.
  solver_->projective.reset();
  solver_->multigrid.reset();
}
Simulation::Simulation(Simulation&& o) noexcept = default;
Simulation& Simulation::operator=(const Simulation& o) {
  if (this != &o) *this = Simulation(o);
  return *this;
}
Simulation& Simulation::operator=(Simulation&& o) noexcept = default;

const Model& Simulation::model() const {
  return *solver_->model;
}
const Material& Simulation::material() const {
  return solver_->material;
}
const SolverOptions& Simulation::options() const {
  return solver_->options;
}
const std::vector<double>& Simulation::mass_kg() const {
  return solver_->mass_kg;
}
const std::vector<uint8_t>& Simulation::fixed() const {
  return solver_->fixed;
}
const std::vector<uint8_t>& Simulation::movable() const {
  return solver_->movable;
}
const std::vector<double>& Simulation::spring_stiffness_n_per_m() const {
  return solver_->springs.stiffness_n_per_m;
}
const model::TetIdentification& Simulation::tet_identification() const {
  static const model::TetIdentification none;
  return solver_->tets.id ? *solver_->tets.id : none;
}

namespace detail {

void refresh(Simulation& sim) {
  Solver& s = sim.solver();
  ++s.setup_version;
  const Model& m = *s.model;
  const int32_t n = m.node_count();
  s.active_nodes.clear();
  for (int32_t i = 0; i < n; ++i) {
    if (s.movable[i]) {
      s.active_nodes.push_back(i);
      continue;
    }
    sim.v.row(i).setZero();
    for (Eigen::MatrixX3d* w : {&s.r, &s.z, &s.p, &s.dv}) w->row(i).setZero();
  }
  const Springs& sp = m.springs;
  s.active_springs.clear();
  if (!s.tets.on)  // otherwise the tetrahedra carry the springs
    for (size_t e = 0; e < sp.size(); ++e)
      if (s.movable[sp.i[e]] || s.movable[sp.j[e]])
        s.active_springs.push_back(static_cast<int32_t>(e));
  s.active_tets.clear();
  if (s.tets.on)
    for (Eigen::Index t = 0; t < m.tets.size(); ++t)
      if (s.movable[m.tets.T(t, 0)] || s.movable[m.tets.T(t, 1)] || s.movable[m.tets.T(t, 2)] ||
          s.movable[m.tets.T(t, 3)]) {
        const auto block = static_cast<int32_t>(t / kTetLanes);
        if (s.active_tets.empty() || s.active_tets.back() != block) s.active_tets.push_back(block);
      }
  refresh_spring_lanes(s);
  refresh_compact_springs(s);
  s.layer_triangles.resize(m.layers.size());
  s.frozen_layer_triangles.resize(m.layers.size());
  for (size_t k = 0; k < m.layers.size(); ++k) {
    const Eigen::MatrixX3i& F = m.layers[k].F;
    std::vector<int32_t>& active = s.layer_triangles[k];
    std::vector<int32_t>& frozen = s.frozen_layer_triangles[k];
    active.clear();
    frozen.clear();
    for (Eigen::Index t = 0; t < F.rows(); ++t)
      (s.movable[F(t, 0)] || s.movable[F(t, 1)] || s.movable[F(t, 2)] ? active : frozen)
          .push_back(static_cast<int32_t>(t));
  }
  refresh_frozen_positions(sim);
}

void refresh_frozen_positions(Simulation& sim) {
  Solver& s = sim.solver();
  const Model& m = *s.model;
  double frozen2 = 0.0;
  for (int32_t i = 0; i < m.node_count(); ++i)
    if (!s.movable[i]) frozen2 = std::max(frozen2, (sim.x.row(i) - m.X.row(i)).squaredNorm());
  s.frozen_max_displacement_mm = std::sqrt(frozen2);
  s.frozen_layer_volume6_mm3.resize(m.layers.size());
  for (size_t k = 0; k < m.layers.size(); ++k) {
    const std::vector<int32_t>& frozen = s.frozen_layer_triangles[k];
    s.frozen_layer_volume6_mm3[k] =
        volume6(m.layers[k].F, sim.x, frozen.data(), static_cast<int64_t>(frozen.size()), 1);
  }
  s.frozen_spring_energy_stale = true;
}

}  // namespace detail

namespace {

// The paper's K on every spring; on a cut model each spring carries the share of its edge's
// material its copies keep (Springs::share).
std::vector<double> uniform_springs(const Springs& springs, double k) {
  std::vector<double> out(springs.size(), k);
  for (size_t e = 0; e < springs.share.size(); ++e) out[e] *= springs.share[e];
  return out;
}

// What the material decides beyond the parameters themselves: masses, spring constants, the
// tetrahedra's identification (when `identify`: it depends only on E, nu and the model), the
// volume terms' tables, the support.
void resolve(Solver& s, bool identify, const KnownTets* known = nullptr) {
  const Model& model = *s.model;
  const Material& material = s.material;
  const auto n = static_cast<size_t>(model.node_count());
  s.mass_kg =
      material.node_mass_kg > 0.0 ? std::vector<double>(n, material.node_mass_kg) : model.mass_kg;
  if (identify) setup_tets(s, known);
  s.springs.stiffness_n_per_m = s.tets.on ? s.tets.id->spring_n_per_m
                                : material.stiffness_n_per_m > 0.0
                                    ? uniform_springs(model.springs, material.stiffness_n_per_m)
                                    : model.springs.stiffness_n_per_m;
  if (material.volume_stiffness_kpa > 0.0 && s.volume.corner_offsets.empty()) setup_volume_term(s);
  setup_support(s);
  // The springs' SIMD lanes only where the springs step by themselves: tetrahedra carry their
  // edges otherwise (lanes_apply()), and making the lanes was 6 ms of a 48k-node cut event.
  if (!s.tets.on && s.lanes.nodes != model.node_count()) setup_spring_lanes(s);
  fill_spring_lanes(s);
}

// Checks what depends on the model as well as on the parameters.
void check_against_model(const Model& model, const Material& material,
                         const SolverOptions& options) {
  if (material.young_modulus_kpa > 0.0 && !model.has_tets())
    throw invalid_input("material.young_modulus_kpa",
                        "the model has no tetrahedra (built with --structure links); build it "
                        "with tetrahedra, or give its springs constants (stiffness_n_per_m)");
  if (material.young_modulus_kpa > 0.0 && options.integrator == Integrator::kProjective)
    throw invalid_input("solver.integrator",
                        "projective dynamics does not carry the tetrahedra's elasticity; use "
                        "implicit_euler (or semi_implicit_euler)");
}

void check_node(const Simulation& s, int32_t i, const char* what) {
  if (i < 0 || i >= s.model().node_count())
    throw invalid_input(
        what, fmt::format("node {} is not in the model (0..{})", i, s.model().node_count() - 1));
}

}  // namespace

void check_parameters(const Material& m, const SolverOptions& o) {
  auto positive = [](double v) { return v > 0.0 && std::isfinite(v); };
  auto non_negative = [](double v) { return v >= 0.0 && std::isfinite(v); };
  const auto got = [](double v) { return fmt::format(", got {}", v); };
  if (!non_negative(m.stiffness_n_per_m))
    throw invalid_input("material.stiffness",
                        "must be >= 0 N/m (0 keeps the model's)" + got(m.stiffness_n_per_m));
  if (!non_negative(m.damping_kg_per_s))
    throw invalid_input("material.damping", "must be >= 0 kg/s" + got(m.damping_kg_per_s));
  if (!non_negative(m.node_mass_kg))
    throw invalid_input("material.node_mass",
                        "must be >= 0 kg (0 uses the model's masses)" + got(m.node_mass_kg));
  if (!non_negative(m.anchor_stiffness_n_per_m))
    throw invalid_input("material.anchor_stiffness",
                        "must be >= 0 N/m" + got(m.anchor_stiffness_n_per_m));
  if (!non_negative(m.mass_damping_per_s))
    throw invalid_input("material.mass_damping", "must be >= 0 1/s" + got(m.mass_damping_per_s));
  if (!non_negative(m.volume_stiffness_kpa))
    throw invalid_input("material.volume_stiffness",
                        "must be >= 0 kPa (0 = off)" + got(m.volume_stiffness_kpa));
  if (!non_negative(m.young_modulus_kpa))
    throw invalid_input("material.young_modulus_kpa",
                        "must be >= 0 kPa (0 = off)" + got(m.young_modulus_kpa));
  if (m.young_modulus_kpa > 0.0) {
    if (!(m.poisson_ratio >= 0.0 && m.poisson_ratio < 0.5))
      throw invalid_input(
          "material.poisson_ratio",
          "must be in [0, 0.5) (0.5 is incompressible: use 0.45-0.49)" + got(m.poisson_ratio));
    if (m.stiffness_n_per_m > 0.0)
      throw invalid_input("material.stiffness",
                          fmt::format("give either the springs' K or the tissue's E "
                                      "(young_modulus_kpa), not both: E identifies the springs; "
                                      "got K = {} N/m and E = {} kPa",
                                      m.stiffness_n_per_m, m.young_modulus_kpa));
  }
  if (!m.gravity_mm_per_s2.allFinite())
    throw invalid_input(
        "material.gravity",
        fmt::format("must be finite, got ({}, {}, {}) mm/s^2", m.gravity_mm_per_s2.x(),
                    m.gravity_mm_per_s2.y(), m.gravity_mm_per_s2.z()));
  if (!positive(o.dt_s)) throw invalid_input("solver.dt", "must be > 0 s" + got(o.dt_s));
  if (!positive(o.rest_speed_mm_per_s))
    throw invalid_input("solver.rest_speed", "must be > 0 mm/s" + got(o.rest_speed_mm_per_s));
  if (o.max_steps < 1)
    throw invalid_input("solver.max_steps", fmt::format("must be >= 1, got {}", o.max_steps));
  if (o.cg_max_iterations < 1)
    throw invalid_input("solver.cg_max_iterations",
                        fmt::format("must be >= 1, got {}", o.cg_max_iterations));
  if (!positive(o.cg_tolerance))
    throw invalid_input("solver.cg_tolerance", "must be > 0" + got(o.cg_tolerance));
  if (o.projective_iterations < 1)
    throw invalid_input("solver.projective_iterations",
                        fmt::format("must be >= 1, got {}", o.projective_iterations));
}

Simulation make_simulation(const Model& model, const Material& material,
                           const SolverOptions& options) {
  return detail::make_simulation(model, material, options, nullptr);
}

namespace detail {

Simulation make_simulation(const Model& model, const Material& material,
                           const SolverOptions& options, const KnownTets* known) {
  check_parameters(material, options);
  check_against_model(model, material, options);
  Simulation sim;
  Solver& s = sim.solver();
  s.model = &model;
  s.material = material;
  s.options = options;
  const int32_t n = model.node_count();
  sim.x = model.X;
  sim.v = Eigen::MatrixX3d::Zero(n, 3);
  sim.f_ext = Eigen::MatrixX3d::Zero(n, 3);
  s.fixed = model.fixed.empty() ? std::vector<uint8_t>(static_cast<size_t>(n), 0) : model.fixed;
  s.movable.resize(static_cast<size_t>(n));
  for (int32_t i = 0; i < n; ++i) s.movable[i] = options.mode == Mode::kGlobal && !s.fixed[i];
  setup_springs(s);
  s.rest_layer_volume_mm3.resize(model.layers.size());
  for (int32_t k = 0; k < model.layer_count(); ++k)
    s.rest_layer_volume_mm3[k] = layer_volume(model, model.X, k);
  s.rest_skin_volume_mm3 = s.rest_layer_volume_mm3.empty() ? 0.0 : s.rest_layer_volume_mm3[0];
  resolve(s, /*identify=*/true, known);
  // Twice the organ's size: an organ held anywhere in its box that swings about the hold as a
  // whole moves no node farther than that (a barely held liver under the stability suite's
  // tools swings 93-378 mm, its own size or more, and comes back to rest); a blow-up, growing
  // by a factor every step, passes it a step or two after the organ's own size.
  s.blowup_limit_mm =
      2.0 * (model.X.colwise().maxCoeff() - model.X.colwise().minCoeff()).norm() + 1.0;
  for (Eigen::MatrixX3d* m : {&s.x_prev, &s.v_prev, &s.r, &s.p, &s.z, &s.y, &s.dv})
    *m = Eigen::MatrixX3d::Zero(n, 3);
  s.diag = Eigen::MatrixX3d::Ones(n, 3);
  refresh(sim);
  return sim;
}

}  // namespace detail

void set_parameters(Simulation& sim, const Material& material, const SolverOptions& options) {
  check_parameters(material, options);
  check_against_model(sim.model(), material, options);
  Solver& s = sim.solver();
  const Material old = s.material;
  const bool to_global = options.mode == Mode::kGlobal && s.options.mode != Mode::kGlobal;
  if (to_global)
    for (size_t i = 0; i < s.movable.size(); ++i) s.movable[i] = !s.fixed[i];
  s.material = material;
  s.options = options;
  const bool tets_changed = material.young_modulus_kpa != old.young_modulus_kpa ||
                            material.poisson_ratio != old.poisson_ratio ||
                            material.tet_elasticity != old.tet_elasticity ||
                            material.tet_model != old.tet_model;
  if (tets_changed || material.node_mass_kg != old.node_mass_kg ||
      material.stiffness_n_per_m != old.stiffness_n_per_m ||
      material.volume_stiffness_kpa != old.volume_stiffness_kpa ||
      material.anchor_stiffness_n_per_m != old.anchor_stiffness_n_per_m)
    resolve(s, tets_changed);
  ++s.setup_version;
  ++s.stiffness_version;
  refresh(sim);  // the active tetrahedra depend on the material; the lists on the mode
}

void fix_nodes(Simulation& sim, const std::vector<int32_t>& nodes) {
  for (int32_t i : nodes) check_node(sim, i, "fixed nodes");
  Solver& s = sim.solver();
  for (int32_t i : nodes) {
    s.fixed[i] = 1;
    s.movable[i] = 0;
    sim.x.row(i) = s.model->X.row(i);
    sim.v.row(i).setZero();
  }
  refresh(sim);
}

namespace {

// Nodes with a stiffness each (support, contact springs): one per node, each node of the model,
// each stiffness finite and >= 0; `what` names them in the message.
void check_node_stiffness(const Simulation& sim, const std::vector<int32_t>& nodes,
                          const std::vector<double>& stiffness_n_per_m, const char* what) {
  if (nodes.size() != stiffness_n_per_m.size())
    throw invalid_input(what, fmt::format("need one stiffness per node, got {} nodes and {} values",
                                          nodes.size(), stiffness_n_per_m.size()));
  for (size_t k = 0; k < nodes.size(); ++k) {
    check_node(sim, nodes[k], what);
    if (!(stiffness_n_per_m[k] >= 0.0 && std::isfinite(stiffness_n_per_m[k])))
      throw invalid_input(what, fmt::format("node {}: stiffness must be >= 0 N/m, got {}", nodes[k],
                                            stiffness_n_per_m[k]));
  }
}

}  // namespace

void support_nodes(Simulation& sim, const std::vector<int32_t>& nodes,
                   const std::vector<double>& stiffness_n_per_m) {
  check_node_stiffness(sim, nodes, stiffness_n_per_m, "supported nodes");
  Solver& s = sim.solver();
  s.support.support_n_per_m.assign(static_cast<size_t>(s.model->node_count()), 0.0);
  for (size_t k = 0; k < nodes.size(); ++k)
    s.support.support_n_per_m[static_cast<size_t>(nodes[k])] += stiffness_n_per_m[k];
  setup_support(s);
  ++s.setup_version;  // the prefactored and stability-limit caches depend on it
  ++s.stiffness_version;
}

std::vector<double> node_support(const Simulation& sim) {
  return sim.solver().support.support_n_per_m;
}

void hold_nodes(Simulation& sim, const std::vector<int32_t>& nodes,
                const Eigen::MatrixX3d& positions) {
  if (positions.rows() != static_cast<Eigen::Index>(nodes.size()))
    throw invalid_input("held nodes", fmt::format("need one position per node, got {} for {}",
                                                  positions.rows(), nodes.size()));
  if (!positions.allFinite()) throw invalid_input("held nodes", "positions must be finite");
  for (int32_t i : nodes) check_node(sim, i, "held nodes");
  Solver& s = sim.solver();
  // An indenter or a grasper moves the same held nodes every step: then only the positions
  // change, and what the step visits (refresh(): every node, spring, tetrahedron and triangle)
  // stays as it is.
  const bool held = std::all_of(nodes.begin(), nodes.end(), [&](int32_t i) { return s.fixed[i]; });
  if (!held) fix_nodes(sim, nodes);  // stops the nodes, lists what moves
  for (size_t k = 0; k < nodes.size(); ++k)
    sim.x.row(nodes[k]) = positions.row(static_cast<Eigen::Index>(k));
  ++s.held_moves;                 // work done on the organ: the energy watch waits
  refresh_frozen_positions(sim);  // the caches of what stays put see the new positions
}

void set_contact_stiffness(Simulation& sim, const std::vector<int32_t>& nodes,
                           const std::vector<double>& stiffness_n_per_m) {
  check_node_stiffness(sim, nodes, stiffness_n_per_m, "contact nodes");
  if (sim.options().integrator == Integrator::kProjective && !nodes.empty())
    throw invalid_input("contact nodes",
                        "projective dynamics prefactors its system: it cannot take contact "
                        "springs that change every step (use implicit Euler)");
  Solver& s = sim.solver();
  SupportTerm& t = s.support;
  const double anchor = s.material.anchor_stiffness_n_per_m;
  const auto refresh_node = [&](int32_t i) {
    const auto u = static_cast<size_t>(i);
    t.stiffness_n_per_m[u] = anchor + t.support_n_per_m[u] + t.contact_n_per_m[u];
  };
  for (int32_t i : t.contact_nodes) t.contact_n_per_m[static_cast<size_t>(i)] = 0.0;
  for (int32_t i : t.contact_nodes) refresh_node(i);
  t.contact_nodes.assign(nodes.begin(), nodes.end());
  for (size_t k = 0; k < nodes.size(); ++k)
    t.contact_n_per_m[static_cast<size_t>(nodes[k])] += stiffness_n_per_m[k];
  for (int32_t i : nodes) refresh_node(i);
  ++s.held_moves;  // work done from outside: the energy watch waits
  // Semi-implicit Euler's substeps follow its stability limit, which the springs lower.
  if (sim.options().integrator == Integrator::kSemiImplicitEuler) ++s.setup_version;
}

void release_nodes(Simulation& sim, const std::vector<int32_t>& nodes) {
  for (int32_t i : nodes) check_node(sim, i, "released nodes");
  Solver& s = sim.solver();
  for (int32_t i : nodes) {
    s.fixed[i] = 0;
    // In local mode only the nodes a tool reaches move; a released node joins them, so that
    // it can return to rest.
    s.movable[i] = 1;
    sim.v.row(i).setZero();
  }
  refresh(sim);
}

void set_local_nodes(Simulation& sim, const std::vector<int32_t>& nodes) {
  for (int32_t i : nodes) check_node(sim, i, "local nodes");
  Solver& s = sim.solver();
  std::fill(s.movable.begin(), s.movable.end(), 0);
  for (int32_t i : nodes)
    if (!s.fixed[i]) s.movable[i] = 1;
  refresh(sim);
}

void reset(Simulation& sim) {
  sim.x = sim.model().X;
  sim.v.setZero();
  sim.solver().dv.setZero();
  sim.time_s = 0.0;
  sim.solver().watch = {};  // a fresh start: whatever made it unstable is gone
  refresh(sim);
}

SimState capture_state(const Simulation& sim) {
  const Solver& s = sim.solver();
  return SimState{sim.x,     sim.v,          sim.f_ext, s.dv,     sim.time_s,
                  sim.steps, sim.recoveries, s.fixed,   s.movable};
}

void restore_state(Simulation& sim, const SimState& st) {
  const Eigen::Index n = sim.model().node_count();
  const auto un = static_cast<size_t>(n);
  for (const Eigen::MatrixX3d* m : {&st.x, &st.v, &st.f_ext, &st.dv})
    if (m->rows() != n)
      throw invalid_input("simulation state",
                          fmt::format("has {} nodes, the model {}", m->rows(), n));
  if (st.fixed.size() != un || st.movable.size() != un)
    throw invalid_input("simulation state", "node flags do not match the model's node count");
  if (!st.x.allFinite() || !st.v.allFinite() || !st.f_ext.allFinite() || !st.dv.allFinite())
    throw invalid_input("simulation state", "holds a value that is not finite");
  for (size_t i = 0; i < un; ++i)
    if (st.fixed[i] > 1 || st.movable[i] > 1 || (st.fixed[i] && st.movable[i]))
      throw invalid_input(
          "simulation state",
          fmt::format("node {}: fixed and movable flags are not 0/1 or both set", i));
  if (!std::isfinite(st.time_s) || st.time_s < 0.0 || st.steps < 0 || st.recoveries < 0)
    throw invalid_input("simulation state", "time, step or recovery count out of range");
  Solver& s = sim.solver();
  sim.x = st.x;
  sim.v = st.v;
  sim.f_ext = st.f_ext;
  s.fixed = st.fixed;
  s.movable = st.movable;
  sim.time_s = st.time_s;
  sim.steps = st.steps;
  sim.recoveries = st.recoveries;
  s.watch = {};  // the watch starts again from the restored state (it is not part of it)
  refresh(sim);  // the active lists and frozen caches; it zeroes dv of nodes that do not move
  s.dv = st.dv;
}

std::vector<int32_t> nodes_near_plane(const Model& model, const Eigen::Vector3d& point,
                                      const Eigen::Vector3d& normal, double distance_mm) {
  const Eigen::Vector3d n = normal.normalized();
  std::vector<int32_t> out;
  for (int32_t i = 0; i < model.node_count(); ++i)
    if (std::abs((model.X.row(i).transpose() - point).dot(n)) <= distance_mm) out.push_back(i);
  return out;
}

double layer_volume(const Model& model, const Eigen::MatrixX3d& x, int32_t layer) {
  const Eigen::MatrixX3i& F = model.layers.at(static_cast<size_t>(layer)).F;
  return volume6(F, x, nullptr, F.rows(), 1) / 6.0;
}

int64_t inverted_tets(const Model& model, const Eigen::MatrixX3d& x) {
  int64_t inverted = 0;
  for (Eigen::Index t = 0; t < model.tets.size(); ++t) {
    const Eigen::Vector3d p0 = x.row(model.tets.T(t, 0)), p1 = x.row(model.tets.T(t, 1)),
                          p2 = x.row(model.tets.T(t, 2)), p3 = x.row(model.tets.T(t, 3));
    if (!((p1 - p0).cross(p2 - p0).dot(p3 - p0) > 0.0)) ++inverted;
  }
  return inverted;
}

}  // namespace lamina::sim
