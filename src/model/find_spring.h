#pragma once
// The spring between two nodes (internal to module model: identify_tets, cut_tetrahedra).

#include <algorithm>
#include <cstdint>

#include "lamina/model/model.h"

namespace lamina::model::detail {

/// The spring between a and b, found in springs sorted by (i, j); -1 if there is none.
inline int32_t find_spring(const Springs& sp, int32_t a, int32_t b) {
  const int32_t i = std::min(a, b), j = std::max(a, b);
  auto lo = std::lower_bound(sp.i.begin(), sp.i.end(), i);
  auto hi = std::upper_bound(lo, sp.i.end(), i);
  const auto first = static_cast<size_t>(lo - sp.i.begin());
  for (size_t e = first; e < static_cast<size_t>(hi - sp.i.begin()); ++e)
    if (sp.j[e] == j) return static_cast<int32_t>(e);
  return -1;
}

}  // namespace lamina::model::detail
