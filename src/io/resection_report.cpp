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
  if (!r.functional) {
    if (!r.functional_missing.empty())
      out.push_back("the functional remnant is not assessed: " + r.functional_missing);
    return out;
  }
  const geometry::FunctionalRemnant& fr = *r.functional;
  const std::string lost = fmt::format("devascularized {:.1f} mL, congested {:.1f} mL",
                                       fr.devascularized_ml, fr.congested_ml);
  // The headline: enough liver by volume, not enough that keeps its inflow and outflow.
  if (r.flr_sufficient && !r.functional_sufficient)
    out.insert(out.begin(),
               fmt::format("the remnant is sufficient geometrically ({:.1f}%) but not "
                           "functionally: {:.1f}% keeps its inflow and outflow, under the {:.0f}% "
                           "a {} liver needs ({})",
                           r.flr_percent, r.functional_flr_percent, r.flr_threshold_percent,
                           geometry::to_string(r.liver), lost));
  else if (fr.lost_ml > 0.0)
    out.push_back(
        fmt::format("the resection cuts {:.1f} mL of the remnant off its vessels ({}): "
                    "functional remnant {:.1f}%",
                    fr.lost_ml, lost, r.functional_flr_percent));
  for (const auto& t : fr.trees) {
    if (t.divided > 0)
      out.push_back(fmt::format(
          "{}: {} branch{} divided, {:.1f} mL of the remnant {} after it", t.name, t.divided,
          t.divided == 1 ? "" : "es", t.lost_ml,
          t.kind == geometry::VesselTreeKind::kPortal ? "devascularized" : "congested"));
    if (t.unrooted_mm > 0.0)
      out.push_back(
          fmt::format("{}: {:.0f} mm of centreline in pieces that reach no root (gaps "
                      "over 5 mm, blobs): their tissue is given to the nearest branch "
                      "that does",
                      t.name, t.unrooted_mm));
  }
  if (!fr.portal)
    out.push_back("devascularization is not assessed: no portal vein among the structures");
  if (!fr.hepatic)
    out.push_back("congestion is not assessed: no hepatic veins among the structures");
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
  for (const auto& t : r.tumours) {
    tumours.push_back({{"name", t.name},
                       {"label", t.label},
                       {"piece", t.piece},
                       {"volume_ml", round2(t.volume_ml)},
                       {"centre_mm", vec(t.centre_mm)},
                       {"side", t.side},
                       {"margin_mm", round2(t.margin_mm)},
                       {"nearest_surface_point_mm", vec(t.nearest_mm)},
                       {"clear", t.clear}});
    if (t.territory) {
      const auto& tt = *t.territory;
      tumours.back()["portal_territory"] =
          ojson{{"tree", tt.tree},
                {"branches", tt.branches},
                {"subtree_branch", tt.subtree >= 0 ? ojson(tt.subtree) : ojson(nullptr)},
                {"territory_ml", round2(tt.territory_ml)}};
    }
  }
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
  if (r.functional) {
    const geometry::FunctionalRemnant& fr = *r.functional;
    ojson trees = ojson::array();
    for (const auto& t : fr.trees) {
      ojson branches = ojson::array();
      for (const auto& b : t.branches)
        branches.push_back({{"id", b.id},
                            {"parent", b.parent},
                            {"length_mm", round2(b.length_mm)},
                            {"radius_mm", round2(b.radius_mm)},
                            {"territory_ml", round2(b.territory_ml)},
                            {"remnant_ml", round2(b.remnant_ml)},
                            {"lost_ml", round2(b.lost_ml)},
                            {"state", b.state}});
      trees.push_back({{"name", t.name},
                       {"kind", t.kind == geometry::VesselTreeKind::kPortal ? "portal" : "hepatic"},
                       {"roots", t.roots},
                       {"bridged_gaps", t.bridged_gaps},
                       {"unrooted_mm", round2(t.unrooted_mm)},
                       {"branches_divided", t.divided},
                       {"lost_ml", round2(t.lost_ml)},
                       {"branches", branches}});
    }
    j["functional_remnant"] = {{"assessed", {{"portal", fr.portal}, {"hepatic", fr.hepatic}}},
                               {"remnant_ml", round2(r.remnant_ml)},
                               {"devascularized_ml", round2(fr.devascularized_ml)},
                               {"congested_ml", round2(fr.congested_ml)},
                               {"lost_ml", round2(fr.lost_ml)},
                               {"functional_ml", round2(fr.functional_ml)},
                               {"percent", round2(r.functional_flr_percent)},
                               {"geometric_percent", round2(r.flr_percent)},
                               {"threshold_percent", r.flr_threshold_percent},
                               {"sufficient", r.functional_sufficient},
                               {"trees", trees}};
  } else {
    j["functional_remnant"] = nullptr;
    j["functional_remnant_missing"] = r.functional_missing;
  }
  if (r.segment_landmarks) {
    const auto& lm = *r.segment_landmarks;
    const bool atlas = lm.placed_by == geometry::CouinaudPlacement::kAtlas;
    ojson segments = ojson::array();
    for (int s = 1; s <= 8; ++s)
      segments.push_back(
          {{"segment", s},
           {"volume_ml", round2(r.segment_ml[static_cast<size_t>(s)])},
           {"resected_percent", round2(r.segment_resected_percent[static_cast<size_t>(s)])}});
    j["couinaud_segments"] = {
        {"segments", segments},
        {"placed_by", atlas ? "atlas" : "vessels"},
        {"vessels_not_used",
         r.segment_fallback.empty() ? ojson(nullptr) : ojson(r.segment_fallback)},
        {"landmarks", atlas ? ojson(nullptr)
                            : ojson{{"confluence_mm", vec(lm.confluence_mm)},
                                    {"vein_azimuth_deg", lm.vein_azimuth_deg},
                                    {"portal_level_mm", round2(lm.portal_level_mm)},
                                    {"right_level_mm", round2(lm.right_level_mm)}}},
        {"atlas", atlas ? ojson{{"livers", lm.atlas_livers},
                                {"shape_overlap", round2(lm.atlas_overlap)},
                                {"vessels_lined_up", lm.atlas_vessels}}
                        : ojson(nullptr)},
        {"validated",
         "mean Dice 0.805 (atlas, with the vessels; 0.798 without) and 0.57 (vessels' "
         "landmarks, one merged label) against "
         "3D-IRCADb's expert labels (docs/resection.md); check them"}};
  }
  j["findings"] = resection_findings(r);
  return j.dump(2);
}

}  // namespace lamina::io
