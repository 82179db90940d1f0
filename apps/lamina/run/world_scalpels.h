#pragma once
// A world scene's scalpels in `lamina run` (world_run.cpp): each body's own (its scene's tools),
// moved on the world's clock and cutting that body through the world's one place where a body's
// topology changes (world::advance_scalpels); what they did, for the log and summary.json.

#include <cstdint>
#include <string>
#include <vector>

#include "lamina/interact/scalpel.h"
#include "lamina/io/world_scene.h"

namespace lamina::cli {

/// One body's scalpels and what they have cut.
struct BodyScalpels {
  interact::ScalpelDriver driver;
  int32_t cuts = 0;                         ///< cuts that divided tetrahedra
  int64_t cut_tets = 0;                     ///< tetrahedra divided, over every cut
  int64_t new_nodes = 0;                    ///< nodes added by the copies
  std::vector<std::string> structures_cut;  ///< embedded structures crossed, in order
};

/// Every body's scalpels (none is no error), in the world's body order.
/// \note Throws lamina::Error (kInvalidInput) "SOURCE: bodies[k] ('NAME'): ..." for a scalpel on
///   a body without tetrahedra (interact::make_scalpel_driver), before anything is stepped.
std::vector<BodyScalpels> world_scalpels(const io::ReadyWorld& w, const std::string& source);

/// The simulated time the last blade stops moving (0 without scalpels).
double scalpels_end_s(const std::vector<BodyScalpels>& scalpels);

/// Moves every body's scalpels to the world's time, cutting where they have passed (structures
/// crossed logged as warnings, as a one-organ run does).
/// @return the bodies (indices into w.ids) whose topology changed
std::vector<size_t> advance_world_scalpels(io::ReadyWorld& w, std::vector<BodyScalpels>& scalpels);

}  // namespace lamina::cli
