#pragma once
/// \file
/// A resection plan's report as JSON (the keys of docs/resection.md) and its findings in words.

#include <string>
#include <vector>

#include "lamina/geometry/plan_resection.h"

namespace lamina::io {

/// What a surgical team must look at: a remnant under the liver's threshold, a tumour divided,
/// left in the remnant or resected with less than the wanted margin, a remnant in pieces.
std::vector<std::string> resection_findings(const geometry::ResectionReport& report);

/// The report as a JSON object (two-space indented): input, surface, volumes_ml,
/// future_liver_remnant, margin_wanted_mm, tumours, structures_crossed, remnant_pieces,
/// remnant_fragments_ml, voxels_by_centre, findings. `surface_source` names a surface file.
std::string resection_report_json(const geometry::ResectionReport& report,
                                  const geometry::ResectionSurface& surface,
                                  const std::string& surface_source);

}  // namespace lamina::io
