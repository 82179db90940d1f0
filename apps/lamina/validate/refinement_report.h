#pragma once
// `lamina validate --refine`: the tool's dent as the mesh is refined (docs/validation.md,
// "The dent as the mesh is refined").

#include "commands.h"
#include "lamina/io/scene.h"

namespace lamina::cli {

/// Builds the scene's organ at each of args.refine's skin sizes and presses every model with
/// the same held push (0.4 N over a patch of args.indenter_radius_mm, default the tools' 5 mm,
/// on the same display skin, at the point paper_indentation() or with args.deepest
/// deepest_indentation() finds on the coarsest model), run to rest. Prints the dent at each size
/// against the finest's and the elastic half-space's (Boussinesq) for the same pressure;
/// refinement.csv, summary.json and refinement.png to args.output, the summary to stdout with
/// args.json.
/// \note Throws lamina::Error (kInvalidInput) for fewer than two sizes and as
///   make_ready_scene().
int report_refinement(const ValidateArgs& args, io::Scene scene);

}  // namespace lamina::cli
