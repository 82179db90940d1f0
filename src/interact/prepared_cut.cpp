// A cut in two halves (prepared_cut.h): made from copies on any thread, taken in between two
// steps.
#include "lamina/interact/prepared_cut.h"

#include "lamina/interact/scalpel.h"

namespace lamina::interact {

PreparedCut prepare_cut(const Model& model, const sim::CarrySource& from,
                        const std::vector<Eigen::Vector3d>& path, const Eigen::Vector3d& direction,
                        double depth_mm) {
  PreparedCut p;
  auto cut = std::make_shared<Model>();
  p.report = cut_model_now(model, from.state.x, path, direction, depth_mm, *cut, p.origin);
  if (p.report.cut_tets > 0) {
    p.sim = sim::made_for_cut(from, model, *cut, p.origin, /*prepare=*/true);
    p.cut = std::move(cut);
  }
  return p;
}

std::optional<sim::Simulation> take_cut(std::shared_ptr<const Model>& model, sim::Simulation& sim,
                                        ToolDriver& tools, PreparedCut& prepared,
                                        bool parameters_changed) {
  if (!prepared.cut || !prepared.sim) return std::nullopt;
  sim::Simulation next = std::move(*prepared.sim);
  prepared.sim.reset();
  if (parameters_changed) sim::set_parameters(next, sim.material(), sim.options());
  sim::restore_state(
      next, sim::carried_state(sim::capture_state(sim), *model, *prepared.cut, prepared.origin));
  carry_tools(*model, *prepared.cut, prepared.origin, tools);
  std::optional<sim::Simulation> was(std::move(sim));
  sim = std::move(next);
  model = std::move(prepared.cut);
  // The job reports the structures crossed at rest: where they are now.
  for (model::StructureCut& x : prepared.report.structures_cut)
    x.position_mm = model::from_rest(*model, sim.x, x.position_mm.transpose()).row(0).transpose();
  return was;
}

}  // namespace lamina::interact
