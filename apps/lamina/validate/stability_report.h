#pragma once
// `lamina validate --stability`: the stability suite's report (docs/validation.md, "Stability").

#include "commands.h"
#include "lamina/io/scene.h"
#include "lamina/validate/indentation.h"

namespace lamina::cli {

/// Runs validate::stability_cases() on `model` (its springs and `scene.material` resolved) with
/// the indenter `indentation`; prints the table, writes stability.csv, stability_energy.csv,
/// summary.json and two plots to args.output, and the summary to stdout with args.json.
int report_stability(const ValidateArgs& args, const io::Scene& scene, const Model& model,
                     const validate::Indentation& indentation);

}  // namespace lamina::cli
