// A tree's flow (tree_flow.h): which seeds still reach their root.
#include "lamina/geometry/tree_flow.h"

namespace lamina::geometry {

std::vector<uint8_t> still_connected(const TreeFlow& flow, const std::vector<uint8_t>& blocked) {
  // Each seed comes after the one upstream of it: one pass.
  std::vector<uint8_t> on(flow.seeds(), 0);
  for (size_t s = 0; s < on.size(); ++s) {
    const int32_t up = flow.seed_upstream[s];
    on[s] = blocked[s] == 0 && (up < 0 || on[static_cast<size_t>(up)] != 0) ? 1 : 0;
  }
  return on;
}

}  // namespace lamina::geometry
