// Which tetrahedra the blade divides, and each side's share of their material.
#include <Eigen/Dense>
#include <algorithm>
#include <bit>
#include <cmath>

#include "cut_internal.h"

namespace lamina::model::detail {

double side_share(uint8_t side, const double s[4][4]) {
  const int count = std::popcount(static_cast<unsigned>(side));
  // One corner alone: the corner tetrahedron at the three crossings, s_ij s_ik s_il of the whole.
  if (count == 1 || count == 3) {
    const int lone = count == 1 ? std::countr_zero(static_cast<unsigned>(side))
                                : std::countr_zero(static_cast<unsigned>(~side & 15u));
    double corner = 1.0;
    for (int j = 0; j < 4; ++j)
      if (j != lone) corner *= s[lone][j];
    return count == 1 ? corner : 1.0 - corner;
  }
  // Two and two: the side {a, b} is a prism between the triangles (a, p_ac, p_ad) and
  // (b, p_bc, p_bd) (its two side quads lie in the faces abc and abd; the cut is the third),
  // three tetrahedra whose volumes, in barycentric coordinates, are their determinants.
  int in[2], out[2], ni = 0, no = 0;
  for (int k = 0; k < 4; ++k) (side >> k & 1 ? in[ni++] : out[no++]) = k;
  const int a = in[0], b = in[1], c = out[0], d = out[1];
  auto corner = [](int k) { return Eigen::Vector4d::Unit(k); };
  auto on_edge = [&](int i, int j) {
    return Eigen::Vector4d((1.0 - s[i][j]) * corner(i) + s[i][j] * corner(j));
  };
  const Eigen::Vector4d A0 = corner(a), A1 = on_edge(a, c), A2 = on_edge(a, d), B0 = corner(b),
                        B1 = on_edge(b, c), B2 = on_edge(b, d);
  auto volume = [](const Eigen::Vector4d& p, const Eigen::Vector4d& q, const Eigen::Vector4d& r,
                   const Eigen::Vector4d& t) {
    Eigen::Matrix4d m;
    m << p.transpose(), q.transpose(), r.transpose(), t.transpose();
    return std::abs(m.determinant());
  };
  return volume(A0, A1, A2, B0) + volume(A1, A2, B0, B1) + volume(A2, B0, B1, B2);
}

void divide_tets(const Eigen::MatrixX4i& T, const Crossings& crossings,
                 std::vector<Division>& divided, int64_t& partly) {
  divided.clear();
  partly = 0;
  for (int32_t t : crossings.near_tets) {
    double s[4][4] = {};
    bool crossed[4][4] = {};
    int ncrossed = 0;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) {
        if (i == j) continue;
        s[i][j] = crossings.fraction(T(t, i), T(t, j));
        crossed[i][j] = s[i][j] >= 0.0;
        if (i < j && crossed[i][j]) ++ncrossed;
      }
    if (ncrossed == 0) continue;
    // The corners joined by edges the blade does not cross are on one side.
    uint8_t side = 1;
    for (bool grew = true; grew;) {
      grew = false;
      for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
          if ((side >> i & 1) && !(side >> j & 1) && i != j && !crossed[i][j])
            side |= static_cast<uint8_t>(1 << j), grew = true;
    }
    const int n = std::popcount(static_cast<unsigned>(side));
    // Divided: two sides, each edge between them crossed and none within one. Otherwise the
    // blade's edge ends inside the tetrahedron (or a side would be split again): it stays whole.
    bool within = false;  // a crossed edge inside a side
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j)
        if (crossed[i][j] && ((side >> i & 1) == (side >> j & 1))) within = true;
    if (n == 4 || within || ncrossed != n * (4 - n)) {
      ++partly;
      continue;
    }
    const double share = std::clamp(side_share(side, s), kMinCutShare, 1.0 - kMinCutShare);
    divided.push_back({t, side, share});
  }
}

}  // namespace lamina::model::detail
