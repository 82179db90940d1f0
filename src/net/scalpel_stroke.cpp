// The network scalpel's strokes, and the cut events sent back for them.
#include "scalpel_stroke.h"

#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include "lamina/core/error.h"

namespace lamina::net {

// Poses closer than this to the last one add nothing to the path (a hand held still).
constexpr double kMinStepMm = 0.5;

void ScalpelStroke::add(int from, const Eigen::Vector3d& tip, const Eigen::Vector3d& axis,
                        double now_s) {
  client = from;
  if (tips.empty() || (tip - tips.back()).norm() >= kMinStepMm) tips.push_back(tip);
  axis_sum += axis;
  last_pose_s = now_s;
}

std::string ScalpelStroke::finish(world::OrganLoop& loop, double depth_mm) {
  return finish([&loop](std::vector<Eigen::Vector3d> top, const Eigen::Vector3d& axis,
                        double depth) { loop.cut(std::move(top), axis, depth); },
                depth_mm);
}

std::string ScalpelStroke::finish(const Cut& cut, double depth_mm) {
  std::string said;
  if (tips.size() < 2) {
    said = "the scalpel's stroke was too short to cut (it moved less than 0.5 mm)";
  } else if (!(axis_sum.norm() > 1e-9)) {
    said = "the scalpel's stroke turned its blade every way: no direction to cut along";
  } else {
    // The blade: its edge from depth_mm behind the tip to the tip, along the mean axis.
    const Eigen::Vector3d axis = axis_sum.normalized();
    std::vector<Eigen::Vector3d> top = tips;
    for (Eigen::Vector3d& p : top) p -= depth_mm * axis;
    try {
      cut(top, axis, depth_mm);
      said = fmt::format("the scalpel's stroke of {} poses cuts {:.1f} mm deep", tips.size(),
                         depth_mm);
    } catch (const Error& e) {
      said = std::string("the scalpel's stroke does not cut: ") + e.what();
    }
  }
  client = -1;
  tips.clear();
  axis_sum.setZero();
  return said;
}

namespace {

// What one cut did to one model, positions in `frame`: cut_tets, pieces, structures_cut.
nlohmann::json report_json(const model::CutReport& r, igtlink::Frame frame) {
  nlohmann::json pieces = nlohmann::json::array(), crossed = nlohmann::json::array();
  for (const model::CutPiece& p : r.pieces)
    pieces.push_back({{"volume_ml", p.volume_mm3 / 1000.0}, {"mass_g", p.mass_kg * 1000.0}});
  for (const model::StructureCut& c : r.structures_cut) {
    const Eigen::Vector3d at = igtlink::change_frame(c.position_mm, frame);
    crossed.push_back({{"name", c.name},
                       {"role", std::string(role_name(c.role))},
                       {"position_mm", {at.x(), at.y(), at.z()}},
                       {"diameter_mm", c.diameter_mm},
                       {"closed", c.closed}});
  }
  return {{"cut_tets", r.cut_tets}, {"pieces", pieces}, {"structures_cut", crossed}};
}

}  // namespace

// Names come from the model; dump() escapes what is not ASCII (the STRING is US-ASCII).
std::string cut_event_text(const world::LoopSnapshot& snap, igtlink::Frame frame) {
  nlohmann::json j = report_json(snap.last_cut, frame);
  j["cuts"] = snap.cuts;
  return j.dump(-1, ' ', /*ensure_ascii=*/true);
}

std::string cut_event_text(const world::WorldSnapshot& snap, igtlink::Frame frame) {
  nlohmann::json bodies = nlohmann::json::array();
  int64_t tets = 0;
  for (const auto& [name, report] : snap.last_cut) {
    nlohmann::json b = report_json(report, frame);
    b["name"] = name;
    bodies.push_back(std::move(b));
    tets += report.cut_tets;
  }
  return nlohmann::json{{"cuts", snap.cuts}, {"cut_tets", tets}, {"bodies", bodies}}.dump(
      -1, ' ', /*ensure_ascii=*/true);
}

}  // namespace lamina::net
