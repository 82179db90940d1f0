// `lamina resect`: plan a resection on a segmentation (docs/resection.md): the future liver
// remnant, each tumour's margin, the structures the surface divides, the remnant's pieces;
// written as a report (text or JSON), the parts as a label volume and the surface as meshes.
#include <fmt/format.h>

#include <charconv>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>

#include "commands.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/geometry/display_skin.h"
#include "lamina/geometry/make_phantom.h"
#include "lamina/geometry/plan_resection.h"
#include "lamina/geometry/winding_number.h"
#include "lamina/io/label_volume_io.h"
#include "lamina/io/mesh_file.h"
#include "lamina/io/model_file.h"
#include "lamina/io/resection_input.h"
#include "lamina/io/resection_report.h"
#include "lamina/model/embed_surface.h"
#include "lamina/model/plan_on_model.h"
#include "plots.h"
#include "resection_picture.h"
#include "structure_entry.h"

namespace lamina::cli {
namespace {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

// "X,Y,Z" as three finite numbers; `what` names the option in the error.
Eigen::Vector3d parse_point(const std::string& text, const std::string& what) {
  Eigen::Vector3d p;
  size_t start = 0;
  for (int c = 0; c < 3; ++c) {
    const size_t end = c < 2 ? text.find(',', start) : text.size();
    if (end == std::string::npos) break;
    const char* first = text.data() + start;
    const char* last = text.data() + end;
    while (first < last && *first == ' ') ++first;
    const auto [ptr, ec] = std::from_chars(first, last, p[c]);
    if (ec != std::errc() || ptr != last || !std::isfinite(p[c]))
      throw invalid_input(what, "'" + text + "' is not three numbers X,Y,Z (mm)");
    start = end + 1;
    if (c == 2) return p;
  }
  throw invalid_input(what, "'" + text + "' is not three numbers X,Y,Z (mm)");
}

geometry::ResectionSurface parse_plane(const std::string& text) {
  const size_t colon = text.find(':');
  if (colon == std::string::npos)
    throw invalid_input("--plane", "'" + text + "' is not POINT:NORMAL, e.g. 0,0,0:1,0,0");
  try {
    return geometry::plane_surface(parse_point(text.substr(0, colon), "--plane"),
                                   parse_point(text.substr(colon + 1), "--plane"));
  } catch (const Error& e) {
    if (std::string(e.what()).starts_with("--plane")) throw;
    throw invalid_input("--plane", "'" + text + "': " + std::string(e.what()).substr(7));
  }
}

std::string text_of(const geometry::ResectionReport& r) {
  std::string t;
  t += fmt::format("{}: whole {:.1f} mL, remnant {:.1f} mL, resected {:.1f} mL\n", r.input,
                   r.whole_ml, r.remnant_ml, r.resected_ml);
  t += fmt::format("future liver remnant {:.1f}% ({} liver: at least {:.0f}%): {}\n", r.flr_percent,
                   to_string(r.liver), r.flr_threshold_percent,
                   r.flr_sufficient ? "sufficient" : "INSUFFICIENT");
  for (const auto& x : r.tumours) {
    t += fmt::format(
        "{} {}: {:.1f} mL at ({:.1f}, {:.1f}, {:.1f}) mm, {}, margin {:.1f} mm "
        "(wanted {:.1f}){}\n",
        x.name, x.piece, x.volume_ml, x.centre_mm.x(), x.centre_mm.y(), x.centre_mm.z(), x.side,
        x.margin_mm, r.margin_mm, x.clear ? "" : "  <-- not clear");
    if (x.territory && x.territory->subtree >= 0)
      t += fmt::format("  fed by {} branch {}: its territory {:.1f} mL\n", x.territory->tree,
                       x.territory->subtree, x.territory->territory_ml);
  }
  if (r.crossings.empty()) t += "no structure is crossed inside the organ\n";
  for (const auto& c : r.crossings)
    t += fmt::format("crosses {} at ({:.1f}, {:.1f}, {:.1f}) mm, diameter {:.1f} mm\n", c.name,
                     c.position_mm.x(), c.position_mm.y(), c.position_mm.z(), c.diameter_mm);
  t += fmt::format("remnant: {} piece{}", r.remnant_pieces.size(),
                   r.remnant_pieces.size() == 1 ? "" : "s");
  if (r.remnant_fragments_ml > 0.0)
    t += fmt::format(" (and {:.2f} mL of slivers under {:.0f} mL along the cut)",
                     r.remnant_fragments_ml, geometry::kMinPieceMl);
  t += "\n";
  if (r.functional)
    t += fmt::format(
        "functional remnant {:.1f} mL, {:.1f}% ({}): devascularized {:.1f} mL, congested {:.1f} "
        "mL\n",
        r.functional->functional_ml, r.functional_flr_percent,
        r.functional_sufficient ? "sufficient" : "INSUFFICIENT", r.functional->devascularized_ml,
        r.functional->congested_ml);
  if (r.segment_landmarks) {
    const geometry::CouinaudLandmarks& lm = *r.segment_landmarks;
    t +=
        fmt::format("Couinaud segments (check them; placed by the {}):",
                    lm.placed_by == geometry::CouinaudPlacement::kAtlas
                        ? fmt::format("atlas, {} expert-labelled livers of shape overlap {:.2f}{}",
                                      lm.atlas_livers.size(), lm.atlas_overlap,
                                      lm.atlas_vessels ? ", their vessels lined up with these" : "")
                        : std::string("vessels"));
    for (size_t s = 1; s <= 8; ++s)
      t += fmt::format(" {}: {:.0f} mL ({:.0f}% resected){}", s, r.segment_ml[s],
                       r.segment_resected_percent[s], s < 8 ? "," : "\n");
  }
  for (const std::string& f : io::resection_findings(r)) t += "finding: " + f + "\n";
  return t;
}

// The organ's voxels' box centre and diagonal (mm): where the plane's square is drawn.
void parts_extent(const LabelVolume& parts, Eigen::Vector3d& centre, double& diagonal) {
  const GridFrame& f = parts.frame;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = -lo;
  for (int64_t k = 0; k < f.size[2]; ++k)
    for (int64_t j = 0; j < f.size[1]; ++j)
      for (int64_t i = 0; i < f.size[0]; ++i) {
        if (parts.labels[static_cast<size_t>(f.index(i, j, k))] == 0) continue;
        const auto p =
            f.to_physical(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k));
        const Eigen::Vector3d x(p[0], p[1], p[2]);
        lo = lo.cwiseMin(x);
        hi = hi.cwiseMax(x);
      }
  centre = 0.5 * (lo + hi);
  diagonal = (hi - lo).norm();
}

// What the picture shows, from a segmentation or a model.
struct PictureInputs {
  SurfaceMesh organ;
  std::vector<PictureStructure> structures;
  std::function<bool(const Eigen::Vector3d&)> inside;
};

// A label's voxels as a mask cropped to their box, with two voxels of background around.
Mask label_mask(const LabelVolume& v, int32_t label) {
  const GridFrame& f = v.frame;
  std::array<int64_t, 3> lo{f.size[0], f.size[1], f.size[2]}, hi{-1, -1, -1};
  for (int64_t k = 0; k < f.size[2]; ++k)
    for (int64_t j = 0; j < f.size[1]; ++j)
      for (int64_t i = 0; i < f.size[0]; ++i)
        if (v.labels[static_cast<size_t>(f.index(i, j, k))] == label) {
          lo = {std::min(lo[0], i), std::min(lo[1], j), std::min(lo[2], k)};
          hi = {std::max(hi[0], i), std::max(hi[1], j), std::max(hi[2], k)};
        }
  Mask m;
  m.frame = f;
  constexpr int64_t pad = 2;
  for (int a = 0; a < 3; ++a) m.frame.size[a] = hi[a] - lo[a] + 1 + 2 * pad;
  m.frame.origin_mm =
      f.to_physical(static_cast<double>(lo[0] - pad), static_cast<double>(lo[1] - pad),
                    static_cast<double>(lo[2] - pad));
  m.inside.assign(static_cast<size_t>(m.frame.voxel_count()), 0);
  for (int64_t k = lo[2]; k <= hi[2]; ++k)
    for (int64_t j = lo[1]; j <= hi[1]; ++j)
      for (int64_t i = lo[0]; i <= hi[0]; ++i)
        m.inside[static_cast<size_t>(
            m.frame.index(i - lo[0] + pad, j - lo[1] + pad, k - lo[2] + pad))] =
            v.labels[static_cast<size_t>(f.index(i, j, k))] == label;
  return m;
}

PictureInputs picture_inputs(const LabelVolume& v, const Mask& organ,
                             const geometry::ResectionOptions& opt) {
  PictureInputs in;
  in.organ = geometry::display_skin(organ, 60000);
  for (const geometry::ResectionStructure& s : opt.structures)
    in.structures.push_back(
        {s.name, geometry::structure_surface(label_mask(v, s.label), 15000, s.name), s.role});
  // Inside: the organ mask's voxel holding the point (its frame's axes are orthonormal).
  in.inside = [&organ](const Eigen::Vector3d& p) {
    const GridFrame& f = organ.frame;
    int64_t idx[3];
    for (int a = 0; a < 3; ++a) {
      const Eigen::Vector3d axis(f.direction[a], f.direction[3 + a], f.direction[6 + a]);
      const Eigen::Vector3d o(f.origin_mm[0], f.origin_mm[1], f.origin_mm[2]);
      idx[a] = std::llround((p - o).dot(axis) / f.spacing_mm[a]);
      if (idx[a] < 0 || idx[a] >= f.size[a]) return false;
    }
    return organ.inside[static_cast<size_t>(f.index(idx[0], idx[1], idx[2]))] != 0;
  };
  return in;
}

PictureInputs picture_inputs(const Model& m) {
  PictureInputs in;
  const int32_t skin = model::display_skin_index(m);
  in.organ = skin >= 0 ? SurfaceMesh{m.embedded[skin].V, m.embedded[skin].F}
                       : SurfaceMesh{m.X, m.layers[0].F};
  for (const EmbeddedSurface& e : m.embedded)
    if (is_anatomy(e.role)) in.structures.push_back({e.name, {e.V, e.F}, e.role});
  in.inside = [&m](const Eigen::Vector3d& p) {
    return geometry::winding_number(m.X, m.layers[0].F, p) > 0.5;
  };
  return in;
}

}  // namespace

int run_resect(const ResectArgs& a) {
  const auto start = std::chrono::steady_clock::now();
  if (a.plane.empty() == a.surface.empty())
    throw invalid_input("lamina resect",
                        "give the resection surface once: --plane POINT:NORMAL, or --surface FILE "
                        "(.mrk.json, .obj, .ply, .stl, .off)");
  geometry::LiverCondition liver = geometry::LiverCondition::kNormal;
  if (a.liver == "chemotherapy") liver = geometry::LiverCondition::kChemotherapy;
  if (a.liver == "cirrhosis") liver = geometry::LiverCondition::kCirrhosis;
  if (a.format != "nii.gz" && a.format != "nii" && a.format != "nrrd")
    throw invalid_input("--format", "'" + a.format + "' is not nii.gz, nii or nrrd");
  if (!a.output.empty()) check_output_folder(a.output);

  const geometry::ResectionSurface surface =
      a.plane.empty() ? io::read_resection_surface(a.surface) : parse_plane(a.plane);
  geometry::ResectionOptions opt;
  opt.margin_mm = a.margin_mm;
  opt.segments = a.segments;
  opt.segments_from = a.segments_from == "vessels" ? geometry::SegmentPlacement::kVessels
                      : a.segments_from == "atlas" ? geometry::SegmentPlacement::kAtlas
                                                   : geometry::SegmentPlacement::kAuto;
  opt.liver = liver;
  if (!a.keep.empty() && a.keep != "larger") opt.keep_point = parse_point(a.keep, "--keep");
  const bool phantom = a.input == io::kScenePhantom;
  const bool model_input = a.input.ends_with(".vtu");
  opt.organ_labels = a.labels;
  for (const std::string& entry : a.embed) {
    const StructureEntry e = split_structure_entry(entry, "--embed");
    const int32_t label = entry_label(e, entry, "--embed");
    const std::string name = e.name.empty() ? "label " + e.source : e.name;
    const SurfaceRole role = e.role.value_or(geometry::guess_role(name));
    if (!is_anatomy(role))
      throw invalid_input("--embed", "'" + entry +
                                         "': a structure is a vessel, a tumour or a "
                                         "structure");
    opt.structures.push_back({label, name, role});
  }
  if (phantom && a.labels.empty() && a.embed.empty()) {
    opt.organ_labels = geometry::planning_phantom_options().organ_labels;
    opt.structures = geometry::planning_phantom_options().structures;
  }
  // A model: its own surfaces (plan_on_model); a segmentation: its voxels.
  geometry::ResectionPlan plan;
  std::optional<Model> m;
  std::optional<LabelVolume> volume;
  if (model_input) {
    if (!a.labels.empty() || !a.embed.empty())
      throw invalid_input(a.input,
                          "a model's structures are its own: --label and --embed are "
                          "for segmentations");
    if (a.segments)
      throw invalid_input("--segments",
                          "a model holds no vessel centrelines: plan on the segmentation");
    m = io::load_model(a.input);
    plan.report = model::plan_on_model(*m, m->X, surface, opt);
  } else {
    volume = phantom ? geometry::planning_phantom() : read_input(a.input);
    plan = geometry::plan_resection(*volume, geometry::SideOf(surface), opt);
  }
  const geometry::ResectionReport& r = plan.report;
  ojson j = ojson::parse(io::resection_report_json(r, surface, a.surface));

  if (!a.output.empty()) {
    const fs::path out(a.output);
    create_folder(out);
    // A segmentation's parts on its grid; a model has no grid to write them on.
    const std::string parts = model_input ? "" : (out / ("parts." + a.format)).string();
    Eigen::Vector3d centre = surface.point;
    double diagonal = 300.0;
    if (!model_input) {
      io::write_label_volume(plan.parts, parts);
      parts_extent(plan.parts, centre, diagonal);
    }
    SurfaceMesh mesh;
    geometry::surface_triangles(surface, centre, 1.2 * diagonal, mesh.V, mesh.F);
    io::write_mesh(mesh, (out / "surface.obj").string());
    io::write_mesh(mesh, (out / "surface.vtp").string());
    j["outputs"] = {{"surface", {(out / "surface.obj").string(), (out / "surface.vtp").string()}},
                    {"report", (out / "report.json").string()}};
    if (!model_input) {
      j["outputs"]["parts"] = parts;
      j["outputs"]["parts_labels"] = {{"1", "remnant"}, {"2", "resected"}};
    }
    if (r.segment_landmarks) {
      const std::string segments = (out / ("segments." + a.format)).string();
      io::write_label_volume(plan.segments, segments);
      j["outputs"]["segments"] = segments;
    }
    // The functional remnant's volumes: each remnant voxel's function, each tree's territories
    // (a segmentation's; a model's plan has its numbers only).
    if (r.functional && !model_input) {
      const std::string function = (out / ("function." + a.format)).string();
      io::write_label_volume(plan.function, function);
      j["outputs"]["function"] = function;
      j["outputs"]["function_labels"] = {{"1", "functional"},
                                         {"2", "devascularized"},
                                         {"3", "congested"},
                                         {"4", "devascularized and congested"}};
      for (size_t t = 0; t < plan.trees.size(); ++t) {
        const bool portal = plan.trees[t].kind == geometry::VesselTreeKind::kPortal;
        // A second tree of a kind (two portal labels) gets its index in the name.
        bool repeated = false;
        for (size_t u = 0; u < t; ++u) repeated |= plan.trees[u].kind == plan.trees[t].kind;
        const std::string file =
            (out / fmt::format("{}{}.{}", portal ? "territories" : "drainage",
                               repeated ? fmt::format("_{}", t) : "", a.format))
                .string();
        io::write_label_volume(plan.territories[t], file);
        j["outputs"][portal ? "territories" : "drainage"].push_back(
            {{"tree", plan.trees[t].territories.name},
             {"file", file},
             {"labels", "branch id + 1 (functional_remnant.trees[].branches[].id)"}});
      }
    }
    // The picture; without EGL the rest is written and the picture's absence said.
    const std::string picture = (out / "resection.png").string();
    try {
      const PictureInputs in = m ? picture_inputs(*m) : picture_inputs(*volume, plan.organ, opt);
      write_resection_picture(picture, in.organ, in.structures, surface, opt.margin_mm, in.inside);
      j["outputs"]["picture"] = picture;
    } catch (const Error& e) {
      if (e.kind() != ErrorKind::kUnavailable) throw;
      log::warn("lamina resect: no picture: {}", e.what());
      j["outputs"]["picture"] = nullptr;
    }
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  j["seconds"] = std::round(seconds * 100.0) / 100.0;
  if (!a.output.empty()) write_text(fs::path(a.output) / "report.json", j.dump(2) + "\n");
  if (a.json)
    std::printf("%s\n", j.dump(2).c_str());
  else
    std::printf("%s", text_of(r).c_str());
  return 0;
}

}  // namespace lamina::cli
