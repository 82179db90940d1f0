// Resection surfaces (resection_surface.h): planes, triangles and closed curves, and the signed
// distance to them (CGAL's AABB tree for triangles).
#include "lamina/geometry/resection_surface.h"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <Eigen/Geometry>
#include <cmath>

#include "lamina/core/error.h"
#include "lamina/geometry/mesh_measures.h"

namespace lamina::geometry {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Triangles = std::vector<K::Triangle_3>;
using Primitive = CGAL::AABB_triangle_primitive<K, Triangles::const_iterator>;
using AabbTree = CGAL::AABB_tree<CGAL::AABB_traits<K, Primitive>>;

// Two unit vectors spanning the plane with unit normal n.
void plane_axes(const Eigen::Vector3d& n, Eigen::Vector3d& u, Eigen::Vector3d& w) {
  const Eigen::Vector3d other =
      std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  u = n.cross(other).normalized();
  w = n.cross(u);
}

}  // namespace

struct SideOf::Tree {
  Triangles triangles;
  std::vector<Eigen::Vector3d> normals;  // per triangle, unit
  AabbTree tree;
};

ResectionSurface plane_surface(const Eigen::Vector3d& point, const Eigen::Vector3d& normal) {
  if (!point.allFinite() || !normal.allFinite())
    throw invalid_input("plane", "its point and normal must be finite numbers");
  const double length = normal.norm();
  if (!(length > 0.0)) throw invalid_input("plane", "its normal has zero length");
  ResectionSurface s;
  s.is_plane = true;
  s.point = point;
  s.normal = normal / length;
  return s;
}

ResectionSurface mesh_surface(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                              const std::string& source) {
  if (F.rows() == 0) throw invalid_input(source, "the resection surface has no triangles");
  if (!V.allFinite()) throw invalid_input(source, "a vertex of the surface is not finite");
  if (F.minCoeff() < 0 || F.maxCoeff() >= V.rows())
    throw invalid_input(source, "a triangle names a vertex the surface does not have");
  if (!(geometry::surface_area(V, F) > 0.0))
    throw invalid_input(source, "every triangle of the surface is degenerate");
  ResectionSurface s;
  s.is_plane = false;
  s.V = V;
  s.F = F;
  return s;
}

ResectionSurface closed_curve_surface(const std::vector<Eigen::Vector3d>& curve,
                                      const std::string& source) {
  if (curve.size() < 3)
    throw invalid_input(
        source, "a closed curve needs at least 3 points, it has " + std::to_string(curve.size()));
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& p : curve) {
    if (!p.allFinite()) throw invalid_input(source, "a point of the curve is not finite");
    centre += p;
  }
  centre /= static_cast<double>(curve.size());
  // Newell's normal: the curve's area vector, zero for points along one line.
  Eigen::Vector3d area = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < curve.size(); ++i)
    area += (curve[i] - centre).cross(curve[(i + 1) % curve.size()] - centre);
  double extent = 0.0;
  for (const auto& p : curve) extent = std::max(extent, (p - centre).norm());
  if (!(area.norm() > 1e-9 * extent * extent))
    throw invalid_input(source, "the curve's points lie along one line: they span no surface");
  const auto n = static_cast<Eigen::Index>(curve.size());
  Eigen::MatrixX3d V(n + 1, 3);
  Eigen::MatrixX3i F(n, 3);
  V.row(n) = centre.transpose();
  for (Eigen::Index i = 0; i < n; ++i) {
    V.row(i) = curve[static_cast<size_t>(i)].transpose();
    F.row(i) << static_cast<int>(n), static_cast<int>(i), static_cast<int>((i + 1) % n);
  }
  return mesh_surface(V, F, source);
}

void surface_triangles(const ResectionSurface& surface, const Eigen::Vector3d& centre,
                       double size_mm, Eigen::MatrixX3d& V, Eigen::MatrixX3i& F) {
  if (!surface.is_plane) {
    V = surface.V;
    F = surface.F;
    return;
  }
  Eigen::Vector3d u, w;
  plane_axes(surface.normal, u, w);
  const Eigen::Vector3d c = centre - (centre - surface.point).dot(surface.normal) * surface.normal;
  const double h = 0.5 * size_mm;
  V.resize(4, 3);
  V.row(0) = (c - h * u - h * w).transpose();
  V.row(1) = (c + h * u - h * w).transpose();
  V.row(2) = (c + h * u + h * w).transpose();
  V.row(3) = (c - h * u + h * w).transpose();
  F.resize(2, 3);
  F << 0, 1, 2, 0, 2, 3;  // u x w = n: the square's winding faces the front
}

SurfaceMesh triangle_subset(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                            const std::vector<bool>& take) {
  std::vector<int> index(static_cast<size_t>(V.rows()), -1);
  std::vector<Eigen::Vector3i> tris;
  std::vector<Eigen::Vector3d> verts;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    if (!take[static_cast<size_t>(f)]) continue;
    Eigen::Vector3i t;
    for (int c = 0; c < 3; ++c) {
      int& i = index[static_cast<size_t>(F(f, c))];
      if (i < 0) {
        i = static_cast<int>(verts.size());
        verts.push_back(V.row(F(f, c)).transpose());
      }
      t[c] = i;
    }
    tris.push_back(t);
  }
  SurfaceMesh out;
  out.V.resize(static_cast<Eigen::Index>(verts.size()), 3);
  for (size_t v = 0; v < verts.size(); ++v) out.V.row(static_cast<Eigen::Index>(v)) = verts[v];
  out.F.resize(static_cast<Eigen::Index>(tris.size()), 3);
  for (size_t t = 0; t < tris.size(); ++t) out.F.row(static_cast<Eigen::Index>(t)) = tris[t];
  return out;
}

void plane_margin_band(const ResectionSurface& plane, const Eigen::Vector3d& centre, double size_mm,
                       int n, const std::vector<Eigen::Vector3d>& points, double margin_mm,
                       const std::function<bool(const Eigen::Vector3d&)>& keep, SurfaceMesh& band,
                       SurfaceMesh& rest) {
  Eigen::MatrixX3d square;
  Eigen::MatrixX3i two;
  surface_triangles(plane, centre, size_mm, square, two);
  const Eigen::Vector3d o = square.row(0).transpose();
  const Eigen::Vector3d u = (square.row(1) - square.row(0)).transpose();
  const Eigen::Vector3d w = (square.row(3) - square.row(0)).transpose();
  Eigen::MatrixX3d V((n + 1) * (n + 1), 3);
  Eigen::MatrixX3i F(2 * n * n, 3);
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i)
      V.row(j * (n + 1) + i) = (o + (double(i) / n) * u + (double(j) / n) * w).transpose();
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int a = j * (n + 1) + i;
      F.row(2 * (j * n + i)) << a, a + 1, a + n + 2;  // the square's winding: facing the front
      F.row(2 * (j * n + i) + 1) << a, a + n + 2, a + n + 1;
    }
  std::vector<bool> in_band(static_cast<size_t>(F.rows()), false), in_rest(in_band.size(), false);
  const double margin2 = margin_mm * margin_mm;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d c = (V.row(F(f, 0)) + V.row(F(f, 1)) + V.row(F(f, 2))).transpose() / 3.0;
    if (keep && !keep(c)) continue;
    bool near = false;
    for (const Eigen::Vector3d& p : points)
      if ((p - c).squaredNorm() < margin2) {
        near = true;
        break;
      }
    (near ? in_band : in_rest)[static_cast<size_t>(f)] = true;
  }
  band = triangle_subset(V, F, in_band);
  rest = triangle_subset(V, F, in_rest);
}

SideOf::SideOf(const ResectionSurface& surface) : surface_(surface) {
  if (surface.is_plane) return;
  tree_ = std::make_unique<Tree>();
  const Eigen::MatrixX3d& V = surface.V;
  for (Eigen::Index f = 0; f < surface.F.rows(); ++f) {
    const Eigen::Vector3d a = V.row(surface.F(f, 0)), b = V.row(surface.F(f, 1)),
                          c = V.row(surface.F(f, 2));
    const Eigen::Vector3d n = (b - a).cross(c - a);
    if (!(n.norm() > 0.0)) continue;  // degenerate: no side to give
    tree_->triangles.emplace_back(K::Point_3(a.x(), a.y(), a.z()), K::Point_3(b.x(), b.y(), b.z()),
                                  K::Point_3(c.x(), c.y(), c.z()));
    tree_->normals.push_back(n.normalized());
  }
  tree_->tree.rebuild(tree_->triangles.cbegin(), tree_->triangles.cend());
  tree_->tree.accelerate_distance_queries();
  // The tree builds its search structure on the first query: make it here, so that queries
  // from several threads only read.
  if (!tree_->triangles.empty()) (void)tree_->tree.closest_point(tree_->triangles[0].vertex(0));
}

SideOf::~SideOf() = default;
SideOf::SideOf(SideOf&&) noexcept = default;
SideOf& SideOf::operator=(SideOf&&) noexcept = default;

SideQuery SideOf::query(const Eigen::Vector3d& p) const {
  SideQuery q;
  if (surface_.is_plane) {
    q.signed_mm = (p - surface_.point).dot(surface_.normal);
    q.normal = surface_.normal;
    q.nearest = p - q.signed_mm * surface_.normal;
    return q;
  }
  const auto [c, it] = tree_->tree.closest_point_and_primitive(K::Point_3(p.x(), p.y(), p.z()));
  const auto index = static_cast<size_t>(it - tree_->triangles.cbegin());
  q.nearest = Eigen::Vector3d(c.x(), c.y(), c.z());
  q.normal = tree_->normals[index];
  const Eigen::Vector3d d = p - q.nearest;
  // The distance is to the nearest triangle; its side is that triangle's normal's (a point
  // beyond the surface's rim takes the side of the rim's triangle).
  q.signed_mm = d.dot(q.normal) >= 0.0 ? d.norm() : -d.norm();
  return q;
}

}  // namespace lamina::geometry
