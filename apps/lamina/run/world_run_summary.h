#pragma once
// What `lamina run` of a world measured (world_run.cpp steps it): per body and for the whole
// run, summary.json made of it, and the lines printed at the end.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "commands.h"
#include "lamina/io/world_scene.h"
#include "lamina/sim/simulation.h"
#include "world_scalpels.h"

namespace lamina::cli {

/// What the run measured of each body.
struct BodyRecord {
  double max_penetration_mm = 0.0;
  double max_displacement_mm = 0.0;
  double max_abs_volume_change_pct = 0.0;
  double max_contact_force_mn = 0.0;
  int64_t max_inverted_tets = 0;  // at any step
  sim::StepStats last;
};

/// What the run measured of the whole world.
struct WorldRunRecord {
  bool converged = false;
  sim::Instability unstable = sim::Instability::kNone;
  std::string unstable_body;
  std::vector<double> step_us;
  double contact_us = 0.0, total_us = 0.0;
  double wall_s = 0.0;
  int32_t frames = 0;
  std::vector<BodyRecord> bodies;
  std::vector<std::pair<double, std::string>> tie_files;  ///< ties.pvd's frames
};

/// summary.json: the scene, the run's speed and state, each body (scalpels' cuts included) and
/// the attachments (docs/world.md, "lamina run of a world").
nlohmann::json world_summary_json(const io::WorldScene& scene, const io::ReadyWorld& w,
                                  const WorldRunRecord& loop,
                                  const std::vector<BodyScalpels>& scalpels, double model_s,
                                  double wall_s, const RunArgs& a);

/// The run's lines on stdout, from its summary `sum`: the world, each body, the scalpels, the
/// attachments and what was written (`series` surfaces' series).
void print_world_summary(const io::WorldScene& scene, const io::ReadyWorld& w,
                         const WorldRunRecord& loop, const std::vector<BodyScalpels>& scalpels,
                         const nlohmann::json& sum, double wall_s, const std::string& output,
                         size_t series);

}  // namespace lamina::cli
