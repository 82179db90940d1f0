#pragma once
/// \file
/// The CLI's subcommands, as plain functions of parsed options (main.cpp does the parsing).

#include <array>
#include <string>

#include "lamina/geometry/make_phantom.h"
#include "lamina/io/scene.h"
#include "lamina/model/build_model.h"

namespace lamina::cli {

/// Progress for long work on stderr: an in-place line on a terminal; on a pipe or file, one line
/// per stage when `verbose`, nothing otherwise.
ProgressFn stderr_progress(bool verbose);

struct PhantomArgs {
  std::string output;
  geometry::PhantomOptions options;
};
int run_phantom(const PhantomArgs& args);

struct BuildArgs {
  std::string input = io::kScenePhantom;
  std::string output;
  bool json = false;
  bool quiet = false;
  bool verbose = false;
  model::BuildOptions options;
};
int run_build(const BuildArgs& args);

struct InfoArgs {
  std::string model;
  bool json = false;
};
int run_info(const InfoArgs& args);

struct ExportArgs {
  std::string model;
  std::string output;
  int layer = 0;
};
int run_export(const ExportArgs& args);

struct RunArgs {
  std::string scene;   ///< scene file; empty = the default scene (the paper's poke on the phantom)
  std::string output;  ///< output folder, created if missing
  bool json = false;
  bool quiet = false;
  bool verbose = false;
};
/// Simulates a scene: writes OUTDIR/metrics.csv, summary.json, skin.pvd and frames/ (layout in
/// docs/scenes.md).
int run_run(const RunArgs& args);

}  // namespace lamina::cli
