#include "commands.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

#include "lamina/core/atomic_file.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/interact/tools.h"
#include "lamina/io/label_volume_io.h"
#include "lamina/io/mesh_file.h"
#include "lamina/io/model_file.h"
#include "lamina/io/scene.h"
#include "lamina/io/scene_model.h"
#include "lamina/io/summary_json.h"
#include "lamina/model/compute_rings.h"
#include "lamina/model/summarize_model.h"
#include "lamina/sim/simulation.h"
#include "structure_entry.h"

namespace lamina::cli {

void check_output(const std::string& path, const std::vector<std::string>& extensions,
                  const char* what) {
  bool ok = false;
  for (const auto& e : extensions) ok |= path.ends_with(e);
  if (!ok) {
    std::string list;
    for (const auto& e : extensions) list += (list.empty() ? "" : ", ") + e;
    throw invalid_input(path,
                        std::string("unsupported ") + what + " file extension (use " + list + ")");
  }
  const std::filesystem::path p(path);
  if (p.has_parent_path() && !std::filesystem::is_directory(p.parent_path()))
    throw Error(ErrorKind::kOutput, path + ": cannot write: directory '" +
                                        p.parent_path().string() + "' does not exist");
}

ProgressFn stderr_progress(bool verbose) {
  // On a terminal: one line, overwritten in place (main() clears it before an error). Elsewhere
  // (logs, scripts) one line per stage, with -v only: an error must stay the only line.
  const bool tty = ::isatty(2);
  if (!tty && !verbose) return {};
  return [tty](std::string_view stage, double fraction) {
    if (tty)
      std::fprintf(stderr, "\r\033[K[%3d%%] %.*s%s", static_cast<int>(fraction * 100 + 0.5),
                   static_cast<int>(stage.size()), stage.data(), fraction >= 1.0 ? "\n" : "");
    else
      std::fprintf(stderr, "[%3d%%] %.*s\n", static_cast<int>(fraction * 100 + 0.5),
                   static_cast<int>(stage.size()), stage.data());
  };
}

io::ReadVolumeOptions volume_read_options;

LabelVolume read_input(const std::string& input) {
  return io::read_input(input, volume_read_options);
}

namespace {

Model load_with_rings(const std::string& path) {
  Model m = io::load_model(path);
  m.rings = model::compute_rings(m, std::max(1, m.rings.locality));
  return m;
}

}  // namespace

int run_phantom(const PhantomArgs& a) {
  check_output(a.output, {".nii", ".nii.gz", ".nrrd", ".mha", ".mhd"}, "image");
  const LabelVolume v = geometry::make_phantom(a.options);
  io::write_label_volume(v, a.output);
  int64_t count[6] = {0, 0, 0, 0, 0, 0};
  for (int32_t l : v.labels) ++count[std::clamp(l, 0, 5)];
  const auto ml = [&](int64_t n) {
    return static_cast<double>(n) * v.frame.voxel_volume_mm3() / 1000.0;
  };
  if (a.options.carved_out) {
    // The organ is not a union of labels here: its label and the structures' parts inside it.
    log::info(
        "wrote {}: {} x {} x {} voxels at {} x {} x {} mm, each voxel the liver or a "
        "structure (build it with --label 1 --embed 2=portal_vein,3=tumours,...)",
        a.output, v.frame.size[0], v.frame.size[1], v.frame.size[2], v.frame.spacing_mm[0],
        v.frame.spacing_mm[1], v.frame.spacing_mm[2]);
    log::info(
        "labels: 1 liver {:.1f} mL, 2 portal vein {:.1f} mL, 3 tumours {:.1f} mL, 4 hepatic "
        "veins {:.1f} mL, 5 vena cava {:.1f} mL",
        ml(count[1]), ml(count[2]), ml(count[3]), ml(count[4]), ml(count[5]));
    return 0;
  }
  log::info("wrote {}: {} x {} x {} voxels at {} x {} x {} mm, organ {:.1f} mL", a.output,
            v.frame.size[0], v.frame.size[1], v.frame.size[2], v.frame.spacing_mm[0],
            v.frame.spacing_mm[1], v.frame.spacing_mm[2], ml(count[1] + count[2] + count[3]));
  if (a.options.anatomy)
    log::info("labels: {} liver {:.1f} mL, {} vessel tree {:.1f} mL, {} tumour {:.1f} mL",
              geometry::kPhantomLiver, ml(count[geometry::kPhantomLiver]), geometry::kPhantomVessel,
              ml(count[geometry::kPhantomVessel]), geometry::kPhantomTumour,
              ml(count[geometry::kPhantomTumour]));
  return 0;
}

// --label, --embed and --embed-mask into the build options; the masks are read here.
model::BuildOptions with_structures(const BuildArgs& a) {
  model::BuildOptions o = a.options;
  if (a.labels.size() == 1) o.label = a.labels[0];
  if (a.labels.size() > 1) o.labels = a.labels;
  for (const std::string& entry : a.embed) {
    const StructureEntry e = split_structure_entry(entry, "--embed");
    o.embed.push_back({.name = e.name, .label = entry_label(e, entry, "--embed"), .role = e.role});
  }
  for (const std::string& entry : a.embed_masks) {
    const StructureEntry e = split_structure_entry(entry, "--embed-mask");
    // Unnamed, it is named after the file (build_model's EmbedStructure::name).
    o.embed.push_back({.name = e.name,
                       .mask = std::make_shared<const LabelVolume>(read_input(e.source)),
                       .role = e.role});
  }
  return o;
}

int run_build(const BuildArgs& a) {
  if (!a.organs.empty() || !a.organ_masks.empty()) return run_build_organs(a);
  check_output(a.output, {".vtu"}, "model");
  model::check_build_options(a.options);
  const LabelVolume volume = read_input(a.input);
  const model::BuildOptions options = with_structures(a);
  const model::BuildResult built =
      model::build_model(volume, options, a.quiet ? ProgressFn{} : stderr_progress(a.verbose));
  // The table lists the warnings itself; with --json they go to stderr, stdout stays JSON.
  if (a.json)
    for (const auto& w : built.report.warnings) log::warn("{}: {}", volume.source, w);
  io::save_model(built.model, a.output);
  const model::ModelSummary summary = model::summarize_model(built.model, &built.report);
  if (a.json)
    std::cout << io::summary_json(summary, &built.report, volume.source) << "\n";
  else
    std::cout << io::summary_table(summary, &built.report, volume.source) << "  saved to "
              << a.output << "\n";
  return 0;
}

int run_info(const InfoArgs& a) {
  const Model m = load_with_rings(a.model);
  const model::ModelSummary summary = model::summarize_model(m);
  std::cout << (a.json ? io::summary_json(summary, nullptr, a.model) + "\n"
                       : io::summary_table(summary, nullptr, a.model));
  return 0;
}

int run_export(const ExportArgs& a) {
  check_output(a.output, {".obj", ".ply", ".vtp", ".stl", ".OBJ", ".PLY", ".VTP", ".STL"}, "mesh");
  const Model m = io::load_model(a.model);
  if (a.layer < 0 || a.layer >= m.layer_count())
    throw invalid_input("--layer", "model " + a.model + " has layers 0.." +
                                       std::to_string(m.layer_count() - 1) + ", got " +
                                       std::to_string(a.layer));
  io::write_mesh(model::layer_mesh(m, a.layer), a.output);
  log::info("wrote layer {} of {} to {}", a.layer, a.model, a.output);
  return 0;
}

// ---------------------------------------------------------------------------------------------
// Shared by run, view, figures and validate (`lamina run` itself is in run_command.cpp).

namespace fs = std::filesystem;

void check_output_folder(const std::string& dir) {
  std::error_code ec;
  const fs::path p = fs::absolute(dir, ec);
  if (fs::exists(p, ec) && !fs::is_directory(p, ec))
    throw Error(ErrorKind::kOutput, dir + ": cannot write: it exists and is not a folder");
  fs::path probe = p;
  while (!fs::exists(probe, ec) && probe.has_parent_path() && probe != probe.parent_path())
    probe = probe.parent_path();
  if (!fs::is_directory(probe, ec))
    throw Error(ErrorKind::kOutput,
                dir + ": cannot write: '" + probe.string() + "' is not a folder");
  if (::access(probe.c_str(), W_OK | X_OK) != 0)
    throw Error(ErrorKind::kOutput,
                dir + ": cannot write: folder '" + probe.string() + "' is not writable");
}

void create_folder(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    throw Error(ErrorKind::kOutput, dir.string() + ": cannot create the folder: " + ec.message());
}

}  // namespace lamina::cli
