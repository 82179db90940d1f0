// The tetrahedra and springs a cut left as they were, found by walking the two models' lists
// together (a carried simulation takes their constants instead of identifying them again).
#include <algorithm>
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

std::vector<int32_t> same_springs(const Model& before, const Model& cut,
                                  const std::vector<int32_t>& origin) {
  const Springs &a = before.springs, &b = cut.springs;
  std::vector<int32_t> same(a.size(), -1);
  if (origin.size() != static_cast<size_t>(cut.node_count())) return same;
  for (size_t v = 0; v < origin.size(); ++v)
    if (origin[v] < 0 || origin[v] >= before.node_count() || (v > 0 && origin[v] < origin[v - 1]))
      return same;
  // The cut's springs, sorted by (i, j), have their ends' origins in the same order (origin is
  // monotone), so one pass over both finds each earlier spring's successors.
  constexpr int32_t kSeveral = -2;
  size_t e = 0;
  for (size_t f = 0; f < b.size(); ++f) {
    const int32_t i = origin[static_cast<size_t>(b.i[f])], j = origin[static_cast<size_t>(b.j[f])];
    while (e < a.size() && (a.i[e] < i || (a.i[e] == i && a.j[e] < j))) ++e;
    if (e == a.size()) break;
    if (a.i[e] == i && a.j[e] == j) same[e] = same[e] == -1 ? static_cast<int32_t>(f) : kSeveral;
  }
  for (int32_t& s : same) s = std::max(s, -1);
  return same;
}

}  // namespace lamina::model
