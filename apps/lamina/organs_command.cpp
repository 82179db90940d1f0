// `lamina build INPUT --organ 1=liver,4=gallbladder --organ-mask kidney.nii.gz=kidney -o DIR`:
// a model per organ (model::build_organs) in DIR/NAME.vtu and DIR/scene.json, a world scene of
// them where the CT has them, attached where their voxels touch (docs/world.md).
#include <fmt/format.h>

#include <charconv>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "lamina/core/atomic_file.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/io/model_file.h"
#include "lamina/model/build_organs.h"

namespace lamina::cli {
namespace {

namespace fs = std::filesystem;

std::vector<model::OrganSource> organ_sources(const BuildArgs& a) {
  std::vector<model::OrganSource> out;
  for (const std::string& entry : a.organs) {
    const size_t eq = entry.find('=');
    model::OrganSource o;
    const char* first = entry.data();
    const char* last = entry.data() + (eq == std::string::npos ? entry.size() : eq);
    const auto [end, ec] = std::from_chars(first, last, o.label);
    if (eq == std::string::npos || ec != std::errc() || end != last || o.label <= 0 ||
        eq + 1 == entry.size())
      throw invalid_input("--organ", "'" + entry + "' is not LABEL=NAME with LABEL a number > 0");
    o.name = entry.substr(eq + 1);
    out.push_back(std::move(o));
  }
  for (const std::string& entry : a.organ_masks) {
    const size_t eq = entry.rfind('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == entry.size())
      throw invalid_input("--organ-mask", "'" + entry + "' is not FILE=NAME");
    out.push_back({.name = entry.substr(eq + 1),
                   .mask = std::make_shared<const LabelVolume>(read_input(entry.substr(0, eq)))});
  }
  return out;
}

// The world scene of the organs: each body its model and the physical default tissue on its
// posterior support, attachments where the voxels touch, contact tolerating the voxel the
// organs' skins were each remeshed within.
std::string organs_scene(const model::OrgansResult& r, const GridFrame& f,
                         const std::string& command) {
  using json = nlohmann::ordered_json;  // keys as a person writes them: the name first
  const double voxel = std::max({f.spacing_mm[0], f.spacing_mm[1], f.spacing_mm[2]});
  json bodies = json::array();
  for (const model::OrganModel& o : r.organs)
    bodies.push_back(
        {{"name", o.name},
         {"model", {{"model", o.name + ".vtu"}}},
         {"material",
          {{"young_modulus_kpa", 6.0}, {"poisson_ratio", 0.45}, {"damping_ratio", 1.0}}}});
  json attachments = json::array();
  for (const model::OrganContact& c : r.contacts)
    attachments.push_back({{"bodies", {c.a, c.b}},
                           {"reach_mm", voxel},
                           {"stiffness_kpa_per_mm", 1.0},
                           {"strength_kpa", 30.0}});
  const json scene = {
      {"bodies", bodies},
      {"attachments", attachments},
      {"contact", {{"rest_overlap_tolerance_mm", 2.0 * voxel}}},
      {"solver", {{"integrator", "implicit_euler"}, {"dt_s", 0.001}}},
      {"output", {{"frame_interval_s", 0.05}}},
  };
  return "// Made by: " + command +
         "\n// The organs where the CT has them, each the physical liver's tissue (E = 6 kPa) on "
         "its\n// posterior support, attached where their voxels touch. Add \"tools\" to a body "
         "to move it\n// (docs/scenes.md, \"World scenes\").\n" +
         scene.dump(2) + "\n";
}

}  // namespace

int run_build_organs(const BuildArgs& a) {
  if (!a.labels.empty())
    throw invalid_input("--label", "cannot be given with --organ: each organ is its own label");
  check_output_folder(a.output);
  const LabelVolume volume = read_input(a.input);
  const std::vector<model::OrganSource> organs = organ_sources(a);
  const model::BuildOptions options = with_structures(a);
  const model::OrgansResult r = model::build_organs(
      volume, organs, options, a.quiet ? ProgressFn{} : stderr_progress(a.verbose));
  const fs::path out(a.output);
  create_folder(out);
  std::string command = "lamina build " + a.input;
  for (const std::string& o : a.organs) command += " --organ " + o;
  for (const std::string& o : a.organ_masks) command += " --organ-mask " + o;
  for (const std::string& e : a.embed) command += " --embed " + e;
  for (const std::string& e : a.embed_masks) command += " --embed-mask " + e;
  command += " -o " + a.output;
  for (const model::OrganModel& o : r.organs)
    io::save_model(o.built.model, (out / (o.name + ".vtu")).string());
  write_file_atomically((out / "scene.json").string(),
                        [&](std::ostream& f) { f << organs_scene(r, volume.frame, command); });
  for (const model::OrganOverlap& o : r.overlaps)
    log::info("{} and {} overlapped by {} voxels: {} given to {}, {} to {} (by their neighbours)",
              o.a, o.b, o.voxels, o.to_a, o.a, o.voxels - o.to_a, o.b);
  for (const model::OrganModel& o : r.organs)
    for (const std::string& w : o.built.report.warnings)
      log::warn("{}: {}: {}", volume.source, o.name, w);
  using nlohmann::json;
  json organs_json = json::array();
  for (const model::OrganModel& o : r.organs) {
    const Model& m = o.built.model;
    organs_json.push_back(
        {{"name", o.name},
         {"model", (out / (o.name + ".vtu")).string()},
         {"voxels", o.voxels},
         {"volume_ml", static_cast<double>(o.voxels) * volume.frame.voxel_volume_mm3() / 1000.0},
         {"nodes", m.node_count()},
         {"skin_vertices", m.layers[0].node_count},
         {"tetrahedra", m.tets.size()},
         {"structures", o.structures}});
  }
  json contacts = json::array();
  for (const model::OrganContact& c : r.contacts)
    contacts.push_back({{"bodies", {c.a, c.b}}, {"voxel_faces", c.faces}});
  json overlaps = json::array();
  for (const model::OrganOverlap& o : r.overlaps)
    overlaps.push_back({{"bodies", {o.a, o.b}}, {"voxels", o.voxels}, {"to_first", o.to_a}});
  const json summary = {{"input", volume.source},
                        {"organs", organs_json},
                        {"touching", contacts},
                        {"overlaps", overlaps},
                        {"scene", (out / "scene.json").string()}};
  if (a.json) {
    std::cout << summary.dump() << "\n";
    return 0;
  }
  std::cout << fmt::format("lamina build: {} organs from {}\n", r.organs.size(), volume.source);
  for (const auto& o : summary["organs"]) {
    std::string held;
    for (const auto& s : o["structures"]) held += (held.empty() ? "" : ", ") + s.get<std::string>();
    std::cout << fmt::format("  {}: {:.1f} mL, {} nodes ({} on the skin), {} tetrahedra{}\n",
                             o["name"].get<std::string>(), o["volume_ml"].get<double>(),
                             o["nodes"].get<int64_t>(), o["skin_vertices"].get<int64_t>(),
                             o["tetrahedra"].get<int64_t>(), held.empty() ? "" : "; holds " + held);
  }
  for (const model::OrganContact& c : r.contacts)
    std::cout << fmt::format("  {} touches {} ({} voxel faces): attached in the scene\n", c.a, c.b,
                             c.faces);
  std::cout << fmt::format("  saved to {}: a model per organ and scene.json (lamina run {})\n",
                           a.output, (out / "scene.json").string());
  return 0;
}

}  // namespace lamina::cli
