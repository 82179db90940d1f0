#pragma once
/// \file
/// Checkpoints of `lamina run`: the whole simulation state, the tools' state and the run's
/// progress so far, in one binary file with a checksum, so that a run stopped at any step can be
/// resumed and continue bit for bit. The layout is in docs/model_format.md ("Checkpoints").

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "lamina/interact/scalpel.h"
#include "lamina/interact/tools.h"
#include "lamina/io/model_file.h"
#include "lamina/model/model.h"
#include "lamina/sim/simulation.h"

namespace lamina::io {

/// One layer's VTK time series so far: (simulated time s, file relative to the output folder).
using FrameList = std::vector<std::pair<double, std::string>>;

/// The run loop's progress (`lamina run`), one piece so that a checkpoint holds it whole.
struct RunProgress {
  int64_t loop_step = 0;  ///< steps taken by the run loop
  int64_t quiet_streak = 0;
  int32_t frame = 0;  ///< frames written
  double next_frame_s = 0.0;
  double max_displacement_mm = 0.0;
  double max_abs_volume_change_pct = 0.0;
  double max_reaction_mn = 0.0;
  std::string metrics_csv;  ///< metrics.csv so far
};

/// What a run with scalpels needs beyond the rest: the model they have cut so far, what the cut
/// carried over, and where each scalpel is.
struct ScalpelCheckpoint {
  /// The model the simulation runs on once cut (null: nothing cut yet), written in the
  /// checkpoint as a model file (format version 5) and checked as one when read.
  std::shared_ptr<const Model> model;
  std::vector<double> support_n_per_m;  ///< per node of `model`: its share of the support
  bool multigrid = false;               ///< the preconditioner implicit Euler kept over the cuts
  std::vector<int32_t> tool_vertex;     ///< per tool, its vertex in `model` (tools by vertex)
  Eigen::MatrixX3d held_forces = Eigen::MatrixX3d(0, 3);    ///< ToolDriver::held_forces
  std::vector<interact::ScalpelDriver::Progress> progress;  ///< per scalpel
  std::vector<interact::CutEvent> events;                   ///< the cuts so far, for the summary
};

/// What `lamina run` needs to continue where it stopped.
struct RunCheckpoint {
  // What the run was of; a resume refuses a scene or model that differs.
  std::string scene_path;  ///< absolute; empty for the built-in default scene
  uint32_t scene_crc = 0;  ///< CRC-32 of the scene file's bytes (0 for the default scene)
  uint32_t model_crc = 0;  ///< model_fingerprint() of the model it ran
  int32_t threads = 0;     ///< OpenMP threads it ran with (a sum's order depends on them)

  sim::SimState state;

  // interact::ToolDriver's state (its tools and routing come from the scene).
  std::vector<uint8_t> tool_active;
  std::vector<interact::ForceRoute> routes;
  std::vector<int32_t> touched;
  interact::Loads loads;

  RunProgress progress;
  std::vector<FrameList> frames;  ///< per written series
  /// Each series' name (frames[k] is series_names[k]'s; a cut adds series as it goes). Empty in
  /// a version 1 checkpoint, whose series are in the order the run makes them.
  std::vector<std::string> series_names;
  std::optional<ScalpelCheckpoint> scalpels;  ///< a run with scalpels (version 2)
};

/// CRC-32 of a file's bytes.
/// \note Throws lamina::Error (kInvalidInput) if the file cannot be read.
uint32_t file_crc(const std::string& path);

/// Writes `checkpoint` to `path` atomically (temporary file, then rename).
/// \note Throws lamina::Error (kOutput) if it cannot be written.
void save_checkpoint(const RunCheckpoint& checkpoint, const std::string& path);

/// Reads a checkpoint written by save_checkpoint().
/// \note Throws lamina::Error (kInvalidInput) with one line "PATH: problem" for a missing,
///   truncated or corrupted file (checksum), another format version, or sizes that disagree.
RunCheckpoint load_checkpoint(const std::string& path);

}  // namespace lamina::io
