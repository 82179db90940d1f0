#include "lamina/core/grid.h"

namespace lamina {

std::array<double, 3> GridFrame::to_physical(double i, double j, double k) const {
  const double s[3] = {i * spacing_mm[0], j * spacing_mm[1], k * spacing_mm[2]};
  std::array<double, 3> p{};
  for (int r = 0; r < 3; ++r)
    p[r] = origin_mm[r] + direction[3 * r] * s[0] + direction[3 * r + 1] * s[1] +
           direction[3 * r + 2] * s[2];
  return p;
}

}  // namespace lamina
