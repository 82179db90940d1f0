// What is wrong with a scalpel, named by its scene key (the scene reader and the driver share
// it): its blade's problems (model::blade_problem), then its times.
#include <fmt/format.h>

#include <cmath>

#include "lamina/interact/scalpel.h"

namespace lamina::interact {

std::optional<std::pair<std::string, std::string>> scalpel_problem(const Scalpel& s) {
  using P = std::pair<std::string, std::string>;
  if (auto problem = model::blade_problem(s.path, s.depth_direction, s.depth_mm)) return problem;
  if (!(std::isfinite(s.start_s) && s.start_s >= 0.0)) return P{"start_s", "must be >= 0 s"};
  if (!(std::isfinite(s.end_s) && s.end_s > s.start_s))
    return P{"end_s", fmt::format("must be after start_s ({})", s.start_s)};
  return std::nullopt;
}

}  // namespace lamina::interact
