// A run with scalpels in a checkpoint: the cut model and what its cuts carried over, so that a
// resumed run simulates the same cut organ and its scalpels go on from where they were.
#include "scalpel_checkpoint.h"

#include <string>

#include "lamina/core/error.h"

namespace lamina::cli {

io::ScalpelCheckpoint capture_scalpels(const std::shared_ptr<const Model>& built,
                                       const std::shared_ptr<const Model>& model,
                                       const interact::ScalpelDriver& scalpels,
                                       const std::vector<interact::CutEvent>& events,
                                       const sim::Simulation& sim,
                                       const interact::ToolDriver& driver) {
  io::ScalpelCheckpoint k;
  if (model != built) k.model = model;
  k.support_n_per_m = sim::node_support(sim);
  k.multigrid = sim::uses_multigrid(sim);
  for (const interact::Tool& t : driver.tools) k.tool_vertex.push_back(t.vertex);
  k.held_forces = driver.held_forces;
  k.progress = scalpels.progress;
  k.events = events;
  return k;
}

void restore_scalpels(const io::ScalpelCheckpoint& k, const std::string& path,
                      const std::shared_ptr<const Model>& built,
                      std::shared_ptr<const Model>& model, interact::ScalpelDriver& scalpels,
                      std::vector<interact::CutEvent>& events, sim::Simulation& sim,
                      interact::ToolDriver& driver) {
  const auto bad = [&](const std::string& problem) {
    return invalid_input(path, problem + ": resume with the scene and model it was written for");
  };
  if (k.progress.size() != scalpels.scalpels.size())
    throw bad("holds " + std::to_string(k.progress.size()) + " scalpels, the scene has " +
              std::to_string(scalpels.scalpels.size()));
  for (const interact::ScalpelDriver::Progress& p : k.progress)
    for (const Eigen::MatrixX3d& c : p.columns)
      if (c.rows() != scalpels.depth_rows + 1 || !c.allFinite())
        throw bad("a scalpel's blade has columns of " + std::to_string(c.rows()) +
                  " points, the scene's has " + std::to_string(scalpels.depth_rows + 1));
  if (k.tool_vertex.size() != driver.tools.size())
    throw bad("holds " + std::to_string(k.tool_vertex.size()) + " tools, the scene has " +
              std::to_string(driver.tools.size()));
  const Model& m = k.model ? *k.model : *built;
  const auto n = static_cast<size_t>(m.node_count());
  for (const int32_t v : k.tool_vertex)
    if (v < 0 || v >= m.surface_node_count()) throw bad("a tool's vertex is not a skin node");
  if ((!k.support_n_per_m.empty() && k.support_n_per_m.size() != n) ||
      (k.held_forces.rows() != 0 && static_cast<size_t>(k.held_forces.rows()) != n) ||
      !k.held_forces.allFinite())
    throw bad("its support or held forces do not fit the cut model's " + std::to_string(n) +
              " nodes");

  if (k.model) {
    // As sim::carry_over() made it at each cut: the same material and options, the
    // preconditioner it kept, each node's share of the support; the state comes next.
    sim::SolverOptions options = sim.options();
    if (options.integrator == sim::Integrator::kImplicitEuler &&
        options.preconditioner == sim::Preconditioner::kAuto)
      options.preconditioner =
          k.multigrid ? sim::Preconditioner::kMultigrid : sim::Preconditioner::kJacobi;
    sim::Simulation cut = sim::make_simulation(*k.model, sim.material(), options);
    std::vector<int32_t> nodes;
    std::vector<double> stiffness;
    for (size_t i = 0; i < k.support_n_per_m.size(); ++i)
      if (k.support_n_per_m[i] != 0.0)
        nodes.push_back(static_cast<int32_t>(i)), stiffness.push_back(k.support_n_per_m[i]);
    sim::support_nodes(cut, nodes, stiffness);
    sim = std::move(cut);
    model = k.model;
  }
  for (size_t t = 0; t < driver.tools.size(); ++t) driver.tools[t].vertex = k.tool_vertex[t];
  driver.held_forces = k.held_forces;
  scalpels.progress = k.progress;
  scalpels.uncut = built;  // the structures crossed are measured on the model as built
  events = k.events;
}

}  // namespace lamina::cli
