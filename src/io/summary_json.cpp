#include "lamina/io/summary_json.h"

#include <fmt/format.h>

#include <nlohmann/json.hpp>

namespace lamina::io {

std::string summary_json(const model::ModelSummary& s, const model::BuildReport* b,
                         const std::string& input) {
  using nlohmann::json;
  json j;
  j["input"] = input;
  if (b) j["build_seconds"] = b->build_seconds;
  j["nodes"] = s.nodes;
  j["springs"] = {{"total", s.springs},
                  {"intra_layer", s.intra_layer_springs},
                  {"inter_layer", s.inter_layer_springs},
                  {"tet_edges", s.volume_springs},
                  {"connected_components", s.spring_components},
                  {"min_rest_length_mm", s.min_rest_length_mm},
                  {"max_rest_length_mm", s.max_rest_length_mm}};
  j["interior_nodes"] = s.interior_nodes;
  j["structure"] = s.tets.count > 0 ? "tets" : "links";
  j["embedded"] = nlohmann::json::array();
  for (const auto& e : s.embedded)
    j["embedded"].push_back({{"name", e.name},
                             {"role", std::string(role_name(e.role))},
                             {"label", e.label},
                             {"vertices", e.vertices},
                             {"faces", e.faces},
                             {"outside", e.outside},
                             {"offset", e.offset},
                             {"max_amplification", e.max_amplification},
                             {"volume_ml", e.volume_ml},
                             {"closed", e.closed},
                             {"manifold", e.manifold}});
  j["trees"] = nlohmann::json::array();
  for (const auto& t : s.trees)
    j["trees"].push_back(
        {{"name", t.name},
         {"kind", t.kind == geometry::VesselTreeKind::kPortal ? "portal" : "hepatic"},
         {"roots", t.roots},
         {"branches", t.branches},
         {"seeds", t.seeds},
         {"bridged_gaps", t.bridged_gaps},
         {"unrooted_mm", t.unrooted_mm}});
  if (s.tets.count > 0)
    j["tets"] = {{"count", s.tets.count},
                 {"min_dihedral_deg", s.tets.min_dihedral_deg},
                 {"mean_dihedral_deg", s.tets.mean_dihedral_deg},
                 {"max_dihedral_deg", s.tets.max_dihedral_deg},
                 {"inverted", s.tets.inverted},
                 {"slivers", s.tets.slivers},
                 {"sliver_below_deg", geometry::TetQuality::kSliverDeg},
                 {"below_10_deg", s.tets.below_10_deg},
                 {"min_volume_mm3", s.tets.min_volume_mm3},
                 {"volume_ml", s.tets.volume_mm3 / 1000.0}};
  j["total_mass_kg"] = s.total_mass_kg;
  j["rings"] = {{"locality", s.locality}, {"entries", s.ring_entries}};
  json layers = json::array();
  for (const auto& l : s.layers) {
    const auto& q = l.quality;
    json o = {{"index", l.index},
              {"vertices", q.vertices},
              {"faces", q.faces},
              {"closed", q.closed},
              {"manifold", q.manifold},
              {"outward", q.outward},
              {"components", q.components},
              {"volume_ml", q.volume_mm3 / 1000.0},
              {"area_mm2", q.area_mm2},
              {"mean_edge_mm", q.mean_edge_mm},
              {"min_edge_mm", q.min_edge_mm},
              {"max_edge_mm", q.max_edge_mm},
              {"min_angle_deg", q.min_angle_deg},
              {"degenerate_faces", q.degenerate_faces},
              {"self_intersecting", l.self_intersecting},
              {"nested", l.nested},
              {"min_gap_to_outer_mm", l.min_gap_mm}};
    if (b && static_cast<size_t>(l.index) < b->layers.size()) {
      o["depth_mm"] = b->layers[l.index].depth_mm;
      o["dropped_components"] = b->layers[l.index].dropped_components;
    }
    layers.push_back(o);
  }
  j["layers"] = layers;
  if (b) {
    const auto& m = b->mask;
    j["mask"] = {{"label", m.label},
                 {"selected_voxels", m.selected_voxels},
                 {"components", m.components},
                 {"dropped_voxels", m.dropped_voxels},
                 {"cavity_voxels_filled", m.cavity_voxels_filled},
                 {"touches_scan_border", m.touches_scan_border},
                 {"volume_ml", b->mask_volume_ml}};
    // Structures carved out of the organ's label: their voxels inside it count as organ.
    // docs/segmentations.md, "What counts as the organ": the voxels each rule took in.
    if (!m.structures.voxels.empty()) {
      j["mask"]["structure_voxels_taken_in"] = m.structures.added;
      j["mask"]["taken_in_by"] = {{"lines", m.structures.by_lines},
                                  {"rays", m.structures.by_rays},
                                  {"whole_tumours", m.structures.by_whole}};
      json st = json::array();
      for (size_t k = 0; k < m.structures.voxels.size(); ++k)
        st.push_back(
            {{"name", k < b->structure_names.size() ? b->structure_names[k] : ""},
             {"role", k < b->structure_roles.size() ? std::string(role_name(b->structure_roles[k]))
                                                    : std::string()},
             {"voxels", m.structures.voxels[k]},
             {"inside_organ", m.structures.inside[k]},
             {"beside_organ", m.structures.beside[k]}});
      j["mask"]["structures"] = st;
    }
    j["skin_volume_error_pct"] = b->skin_volume_error_pct;
    j["layers_requested"] = b->layers_requested;
    j["working_spacing_mm"] = b->working_spacing_mm;
    j["target_edge_mm"] = b->target_edge_mm;
    j["max_depth_mm"] = b->max_depth_mm;
    j["skin_genus"] = b->skin_genus;
    j["skin_attempts"] = b->skin_attempts;
    j["gaps_closed"] = {{"radius_mm", b->gaps.radius_mm},
                        {"voxels", b->gaps.voxels},
                        {"volume_ml", b->gaps.volume_ml}};
    j["tunnels"] = {{"found", b->tunnels.tunnels_before},
                    {"plugged", b->tunnels.tunnels_before - b->tunnels.tunnels_after},
                    {"kept", b->tunnels.tunnels_after},
                    {"largest_plug_radius_mm", b->tunnels.radius_mm},
                    {"plug_voxels", b->tunnels.voxels},
                    {"corner_voxels", b->tunnels.corner_voxels},
                    {"plug_volume_ml", b->tunnels.volume_ml}};
    json stages = json::object();
    for (const auto& [name, sec] : b->stage_seconds) stages[name] = sec;
    j["stage_seconds"] = stages;
    j["warnings"] = b->warnings;
  }
  return j.dump(2);
}

std::string summary_table(const model::ModelSummary& s, const model::BuildReport* b,
                          const std::string& input) {
  std::string out = fmt::format("Lamina model of {}\n", input);
  if (b)
    out += fmt::format(
        "  built in {:.2f} s; mask {:.1f} mL ({} voxels{}{}); skin volume error {:+.2f}%\n",
        b->build_seconds, b->mask_volume_ml, b->mask.kept_voxels,
        b->mask.components > 1 ? fmt::format(", dropped {} voxels in {} other components",
                                             b->mask.dropped_voxels, b->mask.components - 1)
                               : "",
        b->mask.touches_scan_border ? ", touches the scan edge" : "", b->skin_volume_error_pct);
  const std::string body =
      s.spring_components == 1 ? "one" : fmt::format("{}-part", s.spring_components);
  if (s.tets.count > 0) {
    out += fmt::format(
        "  {} nodes ({} inside the layers), {} springs ({} in layers, {} through the volume), {} "
        "connected body, mass {:.3f} kg\n",
        s.nodes, s.interior_nodes, s.springs, s.intra_layer_springs, s.volume_springs, body,
        s.total_mass_kg);
    out += fmt::format(
        "  {} tetrahedra: dihedral angles {:.1f} to {:.1f} deg (mean {:.1f}), {} inverted, {} "
        "slivers (under {:.0f} deg), volume {:.1f} mL\n",
        s.tets.count, s.tets.min_dihedral_deg, s.tets.max_dihedral_deg, s.tets.mean_dihedral_deg,
        s.tets.inverted, s.tets.slivers, geometry::TetQuality::kSliverDeg,
        s.tets.volume_mm3 / 1000.0);
  } else {
    out += fmt::format(
        "  {} nodes, {} springs ({} in layers, {} between layers), {} connected body, mass "
        "{:.3f} kg\n",
        s.nodes, s.springs, s.intra_layer_springs, s.inter_layer_springs, body, s.total_mass_kg);
  }
  out += fmt::format("  rings 0..{} per node: {} entries\n", s.locality - 1, s.ring_entries);
  out +=
      "  layer  depth_mm  vertices  faces  volume_ml  mean_edge_mm  min_angle  parts  closed  "
      "manifold  nested\n";
  for (const auto& l : s.layers) {
    const auto& q = l.quality;
    const double depth =
        b && static_cast<size_t>(l.index) < b->layers.size() ? b->layers[l.index].depth_mm : 0.0;
    out += fmt::format(
        "  {:>5}  {:>8.1f}  {:>8}  {:>5}  {:>9.1f}  {:>12.2f}  {:>9.1f}  {:>5}  {:>6}  {:>8}  "
        "{:>6}\n",
        l.index, depth, q.vertices, q.faces, q.volume_mm3 / 1000.0, q.mean_edge_mm, q.min_angle_deg,
        q.components, q.closed ? "yes" : "NO", q.manifold ? "yes" : "NO", l.nested ? "yes" : "NO");
  }
  for (const auto& e : s.embedded)
    out += fmt::format("  embedded {} ({}, label {}): {} vertices, {} triangles, {:.1f} mL{}\n",
                       e.name, role_name(e.role), e.label, e.vertices, e.faces, e.volume_ml,
                       e.outside > 0
                           ? fmt::format(", {} outside the tetrahedra ({} by an offset), moving at "
                                         "most {:.2f}x their tetrahedron",
                                         e.outside, e.offset, e.max_amplification)
                           : "");
  for (const auto& t : s.trees)
    out += fmt::format(
        "  vessel tree {} ({}): {} root(s), {} branches, {} centreline seeds, {} gap(s) "
        "bridged{}\n",
        t.name, t.kind == geometry::VesselTreeKind::kPortal ? "portal inflow" : "hepatic outflow",
        t.roots, t.branches, t.seeds, t.bridged_gaps,
        t.unrooted_mm > 0.0 ? fmt::format(", {:.0f} mm in no tree", t.unrooted_mm) : "");
  if (b)
    for (const auto& w : b->warnings) out += "  note: " + w + "\n";
  return out;
}

}  // namespace lamina::io
