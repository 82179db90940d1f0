// `lamina resect`: plan a resection on a segmentation (docs/resection.md): the future liver
// remnant, each tumour's margin, the structures the surface divides, the remnant's pieces;
// written as a report (text or JSON), the parts as a label volume and the surface as meshes.
#include <fmt/format.h>

#include <charconv>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>

#include "commands.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/geometry/make_phantom.h"
#include "lamina/geometry/plan_resection.h"
#include "lamina/io/label_volume_io.h"
#include "lamina/io/mesh_file.h"
#include "lamina/io/model_file.h"
#include "lamina/io/resection_input.h"
#include "lamina/io/resection_report.h"
#include "lamina/model/plan_on_model.h"
#include "plots.h"

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
  for (const auto& x : r.tumours)
    t += fmt::format(
        "{} {}: {:.1f} mL at ({:.1f}, {:.1f}, {:.1f}) mm, {}, margin {:.1f} mm "
        "(wanted {:.1f}){}\n",
        x.name, x.piece, x.volume_ml, x.centre_mm.x(), x.centre_mm.y(), x.centre_mm.z(), x.side,
        x.margin_mm, r.margin_mm, x.clear ? "" : "  <-- not clear");
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
  opt.liver = liver;
  if (!a.keep.empty() && a.keep != "larger") opt.keep_point = parse_point(a.keep, "--keep");
  const bool phantom = a.input == io::kScenePhantom;
  const bool model_input = a.input.ends_with(".vtu");
  opt.organ_labels = a.labels;
  for (const std::string& entry : a.embed) {
    const size_t eq = entry.find('=');
    const std::string text = entry.substr(0, eq);
    int32_t label = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), label);
    if (ec != std::errc() || end != text.data() + text.size() || label <= 0)
      throw invalid_input("--embed", "'" + entry + "' is not LABEL[=NAME] with LABEL a number > 0");
    const std::string name = eq == std::string::npos ? "label " + text : entry.substr(eq + 1);
    opt.structures.push_back({label, name, geometry::is_tumour_name(name)});
  }
  if (phantom && a.labels.empty() && a.embed.empty()) {
    opt.organ_labels = geometry::planning_phantom_options().organ_labels;
    opt.structures = geometry::planning_phantom_options().structures;
  }
  // A model: its own surfaces (plan_on_model); a segmentation: its voxels.
  geometry::ResectionPlan plan;
  if (model_input) {
    if (!a.labels.empty() || !a.embed.empty())
      throw invalid_input(a.input,
                          "a model's structures are its own: --label and --embed are "
                          "for segmentations");
    const Model m = io::load_model(a.input);
    plan.report = model::plan_on_model(m, m.X, surface, opt);
  } else {
    const LabelVolume volume = phantom ? geometry::planning_phantom() : read_input(a.input);
    plan = geometry::plan_resection(volume, geometry::SideOf(surface), opt);
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
