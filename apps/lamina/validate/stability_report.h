#pragma once
// `lamina validate --stability`: the stability suite's report (docs/validation.md, "Stability").

#include "commands.h"
#include "lamina/io/scene.h"
#include "lamina/validate/indentation.h"
#include "lamina/validate/stability.h"

namespace lamina::cli {

/// The suite's cases for args (--quick, --case) and the scene's material: throws lamina::Error
/// (kInvalidInput) naming --case when one of args.cases matches no case's name.
std::vector<validate::StabilityCase> chosen_stability_cases(const ValidateArgs& args,
                                                            const io::Scene& scene);

/// Before the build: throws as chosen_stability_cases() does when one of args.cases names no case
/// of the suite with or without projective dynamics (the material, which decides, is not
/// resolved yet).
void check_stability_case_names(const ValidateArgs& args);

/// Runs chosen_stability_cases() on `model` (its springs and `scene.material` resolved) with
/// the indenter `indentation` and the scene's elastic `support`; prints the table, writes
/// stability.csv, stability_energy.csv, summary.json and two plots to args.output, and the summary
/// to stdout with args.json.
int report_stability(const ValidateArgs& args, const io::Scene& scene, const Model& model,
                     const validate::Indentation& indentation,
                     const model::SurfaceSupport& support);

}  // namespace lamina::cli
