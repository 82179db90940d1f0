#include "commands.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <iostream>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/io/label_volume_io.h"
#include "lamina/io/mesh_file.h"
#include "lamina/io/model_file.h"
#include "lamina/io/summary_json.h"
#include "lamina/model/compute_rings.h"
#include "lamina/model/summarize_model.h"

namespace lamina::cli {
namespace {

bool has_suffix(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// Checks an output path before any long work, so a typo does not cost a whole build.
void check_output(const std::string& path, const std::vector<std::string>& extensions,
                  const char* what) {
  bool ok = false;
  for (const auto& e : extensions) ok |= has_suffix(path, e);
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

}  // namespace

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
  int64_t inside = 0;
  for (int32_t l : v.labels) inside += l != 0;
  log::info("wrote {}: {} x {} x {} voxels at {} x {} x {} mm, organ {:.1f} mL", a.output,
            v.frame.size[0], v.frame.size[1], v.frame.size[2], v.frame.spacing_mm[0],
            v.frame.spacing_mm[1], v.frame.spacing_mm[2],
            static_cast<double>(inside) * v.frame.voxel_volume_mm3() / 1000.0);
  return 0;
}

int run_build(const BuildArgs& a) {
  check_output(a.output, {".vtu"}, "model");
  model::check_build_options(a.options);
  const LabelVolume volume =
      a.input == kPhantomInput ? geometry::make_phantom() : io::read_label_volume(a.input);
  const model::BuildResult built =
      model::build_model(volume, a.options, a.quiet ? ProgressFn{} : stderr_progress(a.verbose));
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

}  // namespace lamina::cli
