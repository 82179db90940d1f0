// One organ in real time (organ_loop.h): a world of one body, its loop's snapshot read as the
// organ's.
#include "lamina/world/organ_loop.h"

#include "lamina/core/error.h"

namespace lamina::world {
namespace {

// The organ as the one body of a world: it steps exactly as its simulation alone.
World world_of(std::shared_ptr<const Model> model, sim::Simulation sim,
               const interact::RoutingOptions& routing) {
  if (!model) throw invalid_input("organ loop", "no model");
  interact::check_routing(routing, model->rings.locality);  // here, not in the stepping thread
  return one_body_world(BodyDef{.name = "organ",
                                .model = std::move(model),
                                .simulation = std::move(sim),
                                .tools = {.routing = routing}});
}

// The same, the model the caller's (held, not owned: the caller keeps it).
World world_of_unowned(sim::Simulation sim, const interact::RoutingOptions& routing) {
  std::shared_ptr<const Model> model(std::shared_ptr<const Model>(), &sim.model());
  return world_of(std::move(model), std::move(sim), routing);
}

WorldLoopOptions world_options(const LoopOptions& o) {
  return {.rate_hz = o.rate_hz,
          .real_time = o.real_time,
          .threads = o.threads,
          .publish_interval_s = o.publish_interval_s,
          .dissections = {},
          .background_cuts = o.background_cuts};
}

}  // namespace

interact::RateWindow measured_window(const LoopSnapshot& snap) {
  interact::RateWindow w;
  w.achieved_rate_hz = snap.achieved_rate_hz;
  w.measured_rate_hz = snap.measured_rate_hz;
  w.real_time_factor = snap.real_time_factor;
  w.keeping_up = snap.keeping_up;
  w.mean_step_us = snap.mean_step_us;
  w.worst_jitter_us = snap.worst_jitter_us;
  return w;
}

OrganLoop::OrganLoop(std::shared_ptr<const Model> model, sim::Simulation sim,
                     const interact::RoutingOptions& routing, const LoopOptions& options)
    : loop_(world_of(std::move(model), std::move(sim), routing), world_options(options)),
      id_(loop_.bodies().front().first),
      real_time_(options.real_time) {}

OrganLoop::OrganLoop(sim::Simulation sim, const interact::RoutingOptions& routing,
                     const LoopOptions& options)
    : loop_(world_of_unowned(std::move(sim), routing), world_options(options)),
      id_(loop_.bodies().front().first),
      real_time_(options.real_time) {}

void OrganLoop::set_forces(std::vector<interact::LiveForce> forces,
                           std::optional<uint64_t> model_version) {
  // The model version is the body's topology generation (latest()).
  const uint32_t topology =
      model_version ? static_cast<uint32_t>(*model_version) : loop_.bodies().front().second;
  loop_.set_forces(id_, topology, std::move(forces));
}

void OrganLoop::set_parameters(const sim::Material& material, const sim::SolverOptions& solver,
                               const interact::RoutingOptions& routing) {
  // In real time dt is the clock's: the caller's is not looked at.
  loop_.set_parameters(id_, material, solver, routing,
                       real_time_ ? WorldLoop::Dt::kTheWorlds : WorldLoop::Dt::kGiven);
}

bool OrganLoop::latest(LoopSnapshot& out) const {
  std::lock_guard lock(mutex_);
  loop_.latest(world_);
  const WorldSnapshot& w = world_;
  const BodyView& b = w.bodies.front();
  if (w.generation <= out.generation && out.x.rows() == b.x.rows()) return false;
  out.x = b.x;
  out.stats = b.stats.sim;
  out.time_s = w.time_s;
  out.steps = w.steps;
  out.recoveries = b.recoveries;
  out.generation = w.generation;
  out.achieved_rate_hz = w.rate.achieved_rate_hz;
  out.dt_s = w.dt_s;
  out.material = b.material;
  out.solver = b.solver;
  out.routing = b.routing;
  out.multigrid = b.multigrid;
  out.real_time_factor = w.rate.real_time_factor;
  out.keeping_up = w.rate.keeping_up;
  out.mean_step_us = w.rate.mean_step_us;
  out.measured_rate_hz = w.rate.measured_rate_hz;
  out.worst_jitter_us = w.rate.worst_jitter_us;
  out.reaction_mn = b.reaction_mn;
  out.contact_nodes = b.contact_nodes;
  out.force_nodes = b.force_nodes;
  out.tool_tip_touching = b.tip_touching;
  out.grasped_nodes = b.grasped_nodes;
  out.fixed = b.fixed;
  out.lock_waits = w.lock_waits;
  out.longest_lock_wait_us = w.longest_lock_wait_us;
  out.longest_cut_pause_us = 1e3 * w.longest_cut_ms;
  out.model = b.model;
  out.model_version = b.topology;
  out.cuts = w.cuts;
  out.undoable = w.undoable;
  out.last_cut = w.last_cut.empty() ? model::CutReport{} : w.last_cut.front().second;
  out.cut_error = w.cut_message;
  return true;
}

}  // namespace lamina::world
