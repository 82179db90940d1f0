// The resection report as JSON and its findings (resection_report.h), shared by `lamina resect`
// and lamina.resect() in Python.
#include "lamina/io/resection_report.h"

#include <fmt/format.h>

#include <cmath>
#include <nlohmann/json.hpp>

namespace lamina::io {
namespace {

using ojson = nlohmann::ordered_json;

ojson vec(const Eigen::Vector3d& v) {
  const auto r = [](double x) { return std::round(x * 100.0) / 100.0; };
  return ojson::array({r(v.x()), r(v.y()), r(v.z())});
}

double round2(double x) {
  return std::round(x * 100.0) / 100.0;
}

}  // namespace

std::vector<std::string> resection_findings(const geometry::ResectionReport& r) {
  std::vector<std::string> out;
  if (!r.flr_sufficient)
    out.push_back(
        fmt::format("the future liver remnant, {:.1f}%, is below the {:.0f}% a {} liver "
                    "needs",
                    r.flr_percent, r.flr_threshold_percent, geometry::to_string(r.liver)));
  for (const auto& t : r.tumours) {
    const std::string who = fmt::format("{} {} ({:.1f} mL)", t.name, t.piece, t.volume_ml);
    if (t.side == "divided")
      out.push_back(who + " is divided by the resection surface (no margin)");
    else if (t.side == "remnant")
      out.push_back(
          fmt::format("{} stays in the remnant, {:.1f} mm from the surface", who, t.margin_mm));
    else if (!t.clear)
      out.push_back(
          fmt::format("{} is resected with a {:.1f} mm margin, under the {:.1f} mm "
                      "wanted",
                      who, t.margin_mm, r.margin_mm));
  }
  if (r.remnant_pieces.size() > 1)
    out.push_back(fmt::format("the remnant is left in {} pieces", r.remnant_pieces.size()));
  return out;
}

std::string resection_report_json(const geometry::ResectionReport& r,
                                  const geometry::ResectionSurface& s,
                                  const std::string& surface_source) {
  ojson j;
  j["input"] = r.input;
  ojson surface;
  if (s.is_plane) {
    surface["kind"] = "plane";
    surface["point_mm"] = vec(s.point);
    surface["normal"] = ojson::array({s.normal.x(), s.normal.y(), s.normal.z()});
  } else {
    surface["kind"] = "triangles";
    surface["source"] = surface_source;
    surface["triangles"] = s.F.rows();
  }
  surface["remnant_side"] = r.remnant_in_front ? "front" : "back";
  j["surface"] = surface;
  j["volumes_ml"] = {{"whole", round2(r.whole_ml)},
                     {"remnant", round2(r.remnant_ml)},
                     {"resected", round2(r.resected_ml)}};
  j["future_liver_remnant"] = {{"percent", round2(r.flr_percent)},
                               {"liver", geometry::to_string(r.liver)},
                               {"threshold_percent", r.flr_threshold_percent},
                               {"sufficient", r.flr_sufficient}};
  j["margin_wanted_mm"] = r.margin_mm;
  ojson tumours = ojson::array();
  for (const auto& t : r.tumours)
    tumours.push_back({{"name", t.name},
                       {"label", t.label},
                       {"piece", t.piece},
                       {"volume_ml", round2(t.volume_ml)},
                       {"centre_mm", vec(t.centre_mm)},
                       {"side", t.side},
                       {"margin_mm", round2(t.margin_mm)},
                       {"nearest_surface_point_mm", vec(t.nearest_mm)},
                       {"clear", t.clear}});
  j["tumours"] = tumours;
  ojson crossings = ojson::array();
  for (const auto& c : r.crossings)
    crossings.push_back({{"name", c.name},
                         {"role", std::string(role_name(c.role))},
                         {"label", c.label},
                         {"position_mm", vec(c.position_mm)},
                         {"area_mm2", round2(c.area_mm2)},
                         {"diameter_mm", round2(c.diameter_mm)}});
  j["structures_crossed"] = crossings;
  ojson pieces = ojson::array();
  for (const auto& p : r.remnant_pieces)
    pieces.push_back({{"volume_ml", round2(p.volume_ml)}, {"centre_mm", vec(p.centre_mm)}});
  j["remnant_pieces"] = pieces;
  j["remnant_fragments_ml"] = round2(r.remnant_fragments_ml);
  if (r.remnant_voxels + r.resected_voxels > 0)  // a segmentation's plan, not a model's
    j["voxels_by_centre"] = {{"remnant", r.remnant_voxels}, {"resected", r.resected_voxels}};
  j["findings"] = resection_findings(r);
  return j.dump(2);
}

}  // namespace lamina::io
