// volume_by_plane (volume_by_plane.h): each tetrahedron clipped by the plane, its part in front
// summed.
#include "lamina/geometry/volume_by_plane.h"

#include <Eigen/Geometry>
#include <array>
#include <cmath>

#include "lamina/core/error.h"

namespace lamina::geometry {
namespace {

double tet_volume(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                  const Eigen::Vector3d& d) {
  return std::abs((b - a).dot((c - a).cross(d - a))) / 6.0;
}

// The point where the edge from p (distance dp in front) to q (dq behind) meets the plane.
Eigen::Vector3d crossing(const Eigen::Vector3d& p, double dp, const Eigen::Vector3d& q, double dq) {
  return p + (dp / (dp - dq)) * (q - p);
}

// The volume of the part of tetrahedron p[0..3] with signed distances d[0..3] where d > 0.
double front_part(const std::array<Eigen::Vector3d, 4>& p, const std::array<double, 4>& d) {
  std::array<int, 4> in{}, out{};
  int n_in = 0, n_out = 0;
  for (int c = 0; c < 4; ++c) (d[c] > 0.0 ? in[n_in++] : out[n_out++]) = c;
  if (n_in == 0) return 0.0;
  const double whole = tet_volume(p[0], p[1], p[2], p[3]);
  if (n_out == 0) return whole;
  if (n_in == 1) {  // a corner tetrahedron in front
    const int a = in[0];
    return tet_volume(p[a], crossing(p[a], d[a], p[out[0]], d[out[0]]),
                      crossing(p[a], d[a], p[out[1]], d[out[1]]),
                      crossing(p[a], d[a], p[out[2]], d[out[2]]));
  }
  if (n_out == 1) {  // the whole but a corner tetrahedron behind
    const int a = out[0];
    return whole - tet_volume(p[a], crossing(p[in[0]], d[in[0]], p[a], d[a]),
                              crossing(p[in[1]], d[in[1]], p[a], d[a]),
                              crossing(p[in[2]], d[in[2]], p[a], d[a]));
  }
  // Two corners each side: the front part is a wedge (convex: a tetrahedron cut by a half
  // space) with triangles (a, a-c, a-d) and (b, b-c, b-d), split into three tetrahedra.
  const int a = in[0], b = in[1], c = out[0], e = out[1];
  const Eigen::Vector3d ac = crossing(p[a], d[a], p[c], d[c]),
                        ae = crossing(p[a], d[a], p[e], d[e]);
  const Eigen::Vector3d bc = crossing(p[b], d[b], p[c], d[c]),
                        be = crossing(p[b], d[b], p[e], d[e]);
  return tet_volume(p[a], ac, ae, be) + tet_volume(p[a], ac, bc, be) +
         tet_volume(p[a], p[b], bc, be);
}

// The plane's unit normal; a plane without a direction or not finite is refused.
Eigen::Vector3d unit_normal(const Eigen::Vector3d& point, const Eigen::Vector3d& normal) {
  if (!point.allFinite() || !normal.allFinite())
    throw invalid_input("plane", "its point and normal must be finite numbers");
  const double length = normal.norm();
  if (!(length > 0.0)) throw invalid_input("plane", "its normal has zero length");
  return normal / length;
}

}  // namespace

PlaneSides volume_by_plane(const Eigen::MatrixX3d& X, const Eigen::MatrixX4i& T,
                           const Eigen::Vector3d& point, const Eigen::Vector3d& normal) {
  const Eigen::Vector3d n = unit_normal(point, normal);
  PlaneSides out;
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    std::array<Eigen::Vector3d, 4> p;
    std::array<double, 4> d{};
    for (int c = 0; c < 4; ++c) {
      p[c] = X.row(T(t, c)).transpose();
      d[c] = (p[c] - point).dot(n);
    }
    const double whole = tet_volume(p[0], p[1], p[2], p[3]), front = front_part(p, d);
    out.front_mm3 += front;
    out.back_mm3 += whole - front;
  }
  return out;
}

PlaneSides surface_volume_by_plane(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                   const Eigen::Vector3d& point, const Eigen::Vector3d& normal) {
  const Eigen::Vector3d n = unit_normal(point, normal);
  // The divergence theorem from an apex on the plane: the volume in front is the sum of the
  // signed cones from `point` over the surface's parts in front. The cap that closes it lies in
  // the plane, through the apex, so its cones are flat and it adds nothing.
  const auto cone = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                        const Eigen::Vector3d& c) {
    return (a - point).dot((b - point).cross(c - point)) / 6.0;
  };
  PlaneSides out;
  double whole = 0.0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d p[3] = {V.row(F(f, 0)).transpose(), V.row(F(f, 1)).transpose(),
                                  V.row(F(f, 2)).transpose()};
    const double d[3] = {(p[0] - point).dot(n), (p[1] - point).dot(n), (p[2] - point).dot(n)};
    whole += cone(p[0], p[1], p[2]);
    const int in = (d[0] > 0.0) + (d[1] > 0.0) + (d[2] > 0.0);
    if (in == 0) continue;
    if (in == 3) {
      out.front_mm3 += cone(p[0], p[1], p[2]);
      continue;
    }
    // Rotate so that corner 0 is the one alone on its side; the triangle's winding is kept.
    int lone = 0;
    for (int c = 0; c < 3; ++c)
      if ((d[c] > 0.0) == (in == 1)) lone = c;
    const int b = (lone + 1) % 3, c = (lone + 2) % 3;
    const Eigen::Vector3d ab = crossing(p[lone], d[lone], p[b], d[b]);
    const Eigen::Vector3d ac = crossing(p[lone], d[lone], p[c], d[c]);
    if (in == 1)  // the corner triangle (lone, ab, ac) is in front
      out.front_mm3 += cone(p[lone], ab, ac);
    else  // the quadrilateral (ab, b, c, ac) is in front
      out.front_mm3 += cone(ab, p[b], p[c]) + cone(ab, p[c], ac);
  }
  out.back_mm3 = whole - out.front_mm3;
  return out;
}

PlaneSides voxel_volume_by_plane(const LabelVolume& labels, int32_t label,
                                 const Eigen::Vector3d& point, const Eigen::Vector3d& normal) {
  const Eigen::Vector3d n = unit_normal(point, normal);
  const GridFrame& f = labels.frame;
  // A voxel centre's distance to the plane is linear in its index: d(i, j, k) = d0 + i di + j dj
  // + k dk, each step the direction's column times the spacing, projected on the normal.
  Eigen::Vector3d step;
  for (int c = 0; c < 3; ++c)
    step[c] = f.spacing_mm[c] *
              (f.direction[c] * n.x() + f.direction[3 + c] * n.y() + f.direction[6 + c] * n.z());
  const double d0 =
      (Eigen::Vector3d(f.origin_mm[0], f.origin_mm[1], f.origin_mm[2]) - point).dot(n);
  int64_t front = 0, back = 0;
  for (int64_t k = 0; k < f.size[2]; ++k)
    for (int64_t j = 0; j < f.size[1]; ++j) {
      const double row = d0 + static_cast<double>(j) * step[1] + static_cast<double>(k) * step[2];
      const int32_t* v = labels.labels.data() + f.index(0, j, k);
      for (int64_t i = 0; i < f.size[0]; ++i) {
        if (label == 0 ? v[i] <= 0 : v[i] != label) continue;
        (row + static_cast<double>(i) * step[0] > 0.0 ? front : back) += 1;
      }
    }
  return {static_cast<double>(front) * f.voxel_volume_mm3(),
          static_cast<double>(back) * f.voxel_volume_mm3()};
}

}  // namespace lamina::geometry
