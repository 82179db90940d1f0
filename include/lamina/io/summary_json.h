#pragma once
/// \file
/// The model summary as JSON (for scripts) and as a table (for people).

#include <string>

#include "lamina/model/build_model.h"
#include "lamina/model/summarize_model.h"

namespace lamina::io {

/// One JSON object: input, nodes, springs, layers (and, when `build` is given, how it was
/// built: build_seconds, mask report, warnings, stage timings). Keys: docs/architecture.md.
/// @param[in] summary  from model::summarize_model
/// @param[in] build    the build report, or nullptr for a loaded model
/// @param[in] input    the input path shown under "input"
std::string summary_json(const model::ModelSummary& summary, const model::BuildReport* build,
                         const std::string& input);

/// The same information as an aligned, human-readable table.
std::string summary_table(const model::ModelSummary& summary, const model::BuildReport* build,
                          const std::string& input);

}  // namespace lamina::io
