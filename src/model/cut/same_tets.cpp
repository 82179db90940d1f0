// The tetrahedra a cut left as they were, found by walking the two models' lists together (a
// carried simulation takes their constants instead of identifying them again).
#include <cstdint>
#include <vector>

#include "lamina/model/cut_tetrahedra.h"

namespace lamina::model {

std::vector<int32_t> same_tets(const Model& before, const Model& cut,
                               const std::vector<int32_t>& origin) {
  const Eigen::Index n0 = before.tets.size(), n1 = cut.tets.size();
  std::vector<int32_t> same(static_cast<size_t>(n1), -1);
  if (origin.size() != static_cast<size_t>(cut.node_count())) return same;
  const auto from = [&](Eigen::Index c, Eigen::Index t) {
    for (int k = 0; k < 4; ++k) {
      const int32_t v = cut.tets.T(c, k);
      if (v < 0 || v >= cut.node_count() || origin[static_cast<size_t>(v)] != before.tets.T(t, k))
        return false;
    }
    return true;
  };
  // source[c]: the tetrahedron of `before` copy c came from (-1 once the walk is lost).
  std::vector<int32_t> source(static_cast<size_t>(n1), -1);
  Eigen::Index t = 0;
  for (Eigen::Index c = 0; c < n1; ++c) {
    while (t < n0 && !from(c, t)) ++t;
    if (t == n0) break;
    source[static_cast<size_t>(c)] = static_cast<int32_t>(t);
  }
  for (Eigen::Index c = 0; c < n1; ++c) {
    const int32_t s = source[static_cast<size_t>(c)];
    if (s < 0) break;
    const bool alone = (c == 0 || source[static_cast<size_t>(c - 1)] != s) &&
                       (c + 1 == n1 || source[static_cast<size_t>(c + 1)] != s);
    if (alone && cut.tets.share_of(c) == before.tets.share_of(s) &&
        cut.tets.material_of(c) == before.tets.material_of(s))
      same[static_cast<size_t>(c)] = s;
  }
  return same;
}

}  // namespace lamina::model
