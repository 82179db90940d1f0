#pragma once
// A run with scalpels in a checkpoint (io::ScalpelCheckpoint): what `lamina run` saves beyond
// the simulation's state once its scalpels may have cut the model, and puts back on --resume.

#include <memory>
#include <string>
#include <vector>

#include "lamina/interact/scalpel.h"
#include "lamina/interact/tools.h"
#include "lamina/io/checkpoint.h"
#include "lamina/sim/simulation.h"

namespace lamina::cli {

/// The scalpels' part of a checkpoint: the model they have cut (none while it is still
/// `built`), what the cuts carried over into the simulation and the tools, where each scalpel is.
io::ScalpelCheckpoint capture_scalpels(const std::shared_ptr<const Model>& built,
                                       const std::shared_ptr<const Model>& model,
                                       const interact::ScalpelDriver& scalpels,
                                       const std::vector<interact::CutEvent>& events,
                                       const sim::Simulation& sim,
                                       const interact::ToolDriver& driver);

/// Puts it back: `model` becomes the cut model, `sim` a simulation of it made as the cuts made
/// it (the material, options, preconditioner and support they carried over; its state is the
/// checkpoint's to restore next), the tools' vertices, the scalpels' progress and the events.
/// \note Throws lamina::Error (kInvalidInput) "PATH: problem: resume with the scene and model it
///   was written for" when its sizes disagree with the scene's scalpels and tools or the model.
void restore_scalpels(const io::ScalpelCheckpoint& k, const std::string& path,
                      const std::shared_ptr<const Model>& built,
                      std::shared_ptr<const Model>& model, interact::ScalpelDriver& scalpels,
                      std::vector<interact::CutEvent>& events, sim::Simulation& sim,
                      interact::ToolDriver& driver);

}  // namespace lamina::cli
