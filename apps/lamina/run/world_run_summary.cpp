// `lamina run` of a world: summary.json and the printout (world_run_summary.h).
#include "world_run_summary.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <iostream>

#include "lamina/world/world.h"

namespace lamina::cli {

nlohmann::json world_summary_json(const io::WorldScene& scene, const io::ReadyWorld& w,
                                  const WorldRunRecord& loop,
                                  const std::vector<BodyScalpels>& scalpels, double model_s,
                                  double wall_s, const RunArgs& a) {
  using nlohmann::json;
  json bodies = json::array();
  for (size_t b = 0; b < w.ids.size(); ++b) {
    const world::Body& body = world::body(w.world, w.ids[b]);
    const BodyRecord& r = loop.bodies[b];
    bodies.push_back({
        {"name", body.name},
        {"model", w.bodies[b].source},
        {"nodes", body.model->node_count()},
        {"tetrahedra", body.model->tets.size()},
        {"tools", body.tools.tools.size()},
        {"max_penetration_mm", r.max_penetration_mm},
        {"max_displacement_mm", r.max_displacement_mm},
        {"max_abs_volume_change_pct", r.max_abs_volume_change_pct},
        {"final_rest_error_mm",
         std::sqrt((body.sim.x - body.model->X).rowwise().squaredNorm().maxCoeff())},
        {"final_volume_change_pct", r.last.volume_change_pct},
        {"max_contact_force_n", r.max_contact_force_mn / 1000.0},
        {"max_inverted_tets", r.max_inverted_tets},
        {"converged", r.last.converged},
    });
    const BodyScalpels& sc = scalpels[b];
    if (!sc.driver.scalpels.empty()) {
      json& j = bodies.back();
      j["scalpels"] = sc.driver.scalpels.size();
      j["cuts"] = sc.cuts;
      j["cut_tetrahedra"] = sc.cut_tets;
      j["new_nodes"] = sc.new_nodes;
      j["structures_cut"] = sc.structures_cut;
    }
  }
  json attachments = json::array();
  for (const world::AttachmentId id : w.attachments) {
    const world::Attachment& at = world::attachment(w.world, id);
    int64_t divided = 0, torn = 0;
    for (const world::Tie& t : at.ties) {
      divided += t.divided;
      torn += t.torn;
    }
    attachments.push_back({{"name", at.name},
                           {"ties", at.ties.size()},
                           {"divided", divided},
                           {"torn", torn},
                           {"free", divided + torn == static_cast<int64_t>(at.ties.size())}});
  }
  const world::TieCount ties = world::count_ties(w.world);
  std::vector<double> us = loop.step_us;
  double median = 0.0;
  if (!us.empty()) {
    std::nth_element(us.begin(), us.begin() + static_cast<std::ptrdiff_t>(us.size() / 2), us.end());
    median = us[us.size() / 2];
  }
  json s = {
      {"scene", scene.source},
      {"world", true},
      {"converged", loop.converged},
      {"unstable", loop.unstable != sim::Instability::kNone},
      {"unstable_reason",
       loop.unstable != sim::Instability::kNone ? sim::describe(loop.unstable) : ""},
      {"unstable_body", loop.unstable_body},
      {"steps", w.world.steps},
      {"sim_seconds", w.world.time_s},
      {"dt_s", scene.solver.dt_s},
      {"wall_seconds", wall_s},
      {"model_seconds", model_s},
      {"steps_per_second",
       loop.total_us > 0.0 ? 1e6 * static_cast<double>(loop.step_us.size()) / loop.total_us : 0.0},
      {"median_step_us", median},
      {"contact_share_pct", loop.total_us > 0.0 ? 100.0 * loop.contact_us / loop.total_us : 0.0},
      {"frames", loop.frames},
      {"bodies", bodies},
      {"attachments",
       {{"total", ties.total},
        {"divided", ties.divided},
        {"torn", ties.torn},
        {"each", attachments}}},
      {"dissections", scene.dissections.size()},
  };
  if (a.realtime) {
    s["realtime"] = true;
    s["rate_hz"] = a.rate_hz;
    s["real_time_factor"] = w.world.time_s / std::max(loop.wall_s, 1e-9);
  }
  return s;
}

void print_world_summary(const io::WorldScene& scene, const io::ReadyWorld& w,
                         const WorldRunRecord& loop, const std::vector<BodyScalpels>& scalpels,
                         const nlohmann::json& sum, double wall_s, const std::string& output,
                         size_t series) {
  const world::TieCount ties = world::count_ties(w.world);
  std::cout << fmt::format(
      "lamina run: {} ({} bodies)\n  {} after {} steps ({:.2f} s simulated) in {:.2f} s; "
      "{:.0f} steps/s, contact {:.0f}% of a step\n",
      scene.source, w.ids.size(), loop.converged ? "converged" : "NOT converged", w.world.steps,
      w.world.time_s, wall_s, sum["steps_per_second"].get<double>(),
      sum["contact_share_pct"].get<double>());
  for (const auto& b : sum["bodies"])
    std::cout << fmt::format(
        "  {}: {} nodes, max displacement {:.3g} mm, deepest penetration {:.3g} mm, final rest "
        "error {:.3g} mm, {} inverted tetrahedra at worst\n",
        b["name"].get<std::string>(), b["nodes"].get<int64_t>(),
        b["max_displacement_mm"].get<double>(), b["max_penetration_mm"].get<double>(),
        b["final_rest_error_mm"].get<double>(), b["max_inverted_tets"].get<int64_t>());
  for (size_t b = 0; b < scalpels.size(); ++b)
    if (!scalpels[b].driver.scalpels.empty())
      std::cout << fmt::format("  {}'s scalpels: {} cuts, {} tetrahedra divided, {} new nodes\n",
                               world::body(w.world, w.ids[b]).name, scalpels[b].cuts,
                               scalpels[b].cut_tets, scalpels[b].new_nodes);
  if (ties.total > 0)
    std::cout << fmt::format("  attachments: {} ties, {} divided, {} torn\n", ties.total,
                             ties.divided, ties.torn);
  std::cout << fmt::format("  wrote {}: metrics.csv, summary.json, {} series{} ({} frames)\n",
                           output, series, loop.tie_files.empty() ? "" : " and ties.pvd",
                           loop.frames);
}

}  // namespace lamina::cli
