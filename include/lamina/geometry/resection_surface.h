#pragma once
/// \file
/// The surface a surgeon divides the liver along (resection planning), and which side of it a
/// point is on.

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "lamina/geometry/surface_mesh.h"

namespace lamina::geometry {

/// A resection surface: a plane (point and unit normal), or triangles (a surface drawn in
/// another tool, or spanning a closed curve). Its front is where the plane's normal, or the
/// nearest triangle's outward normal (right-handed winding), points.
struct ResectionSurface {
  bool is_plane = true;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();    ///< a plane's point, mm
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< a plane's unit normal
  Eigen::MatrixX3d V;                                 ///< triangles' vertices, mm
  Eigen::MatrixX3i F;                                 ///< triangles (rows of V)
};

/// A plane through `point` with `normal` (any length but zero). Throws lamina::Error
/// (kInvalidInput, "plane: ...") for a zero or non-finite normal or a non-finite point.
ResectionSurface plane_surface(const Eigen::Vector3d& point, const Eigen::Vector3d& normal);

/// Triangles as a resection surface. Throws lamina::Error (kInvalidInput, naming `source`) for
/// no triangles, a corner index outside V, a vertex not finite, or only degenerate triangles.
ResectionSurface mesh_surface(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                              const std::string& source);

/// The surface spanning a closed curve (its points in order, the last joined to the first): a
/// fan from the points' centroid. Its front is the side the curve turns anticlockwise about.
/// Throws lamina::Error (kInvalidInput, naming `source`) for fewer than three points, a point
/// not finite, or points along one line.
ResectionSurface closed_curve_surface(const std::vector<Eigen::Vector3d>& curve,
                                      const std::string& source);

/// A plane's square, or the triangles themselves, as triangles for drawing and saving: the
/// plane's square is centred on the point nearest `centre` and `size_mm` wide.
void surface_triangles(const ResectionSurface& surface, const Eigen::Vector3d& centre,
                       double size_mm, Eigen::MatrixX3d& V, Eigen::MatrixX3i& F);

/// The margin band on a plane: its square (as surface_triangles() places it) as an n x n grid of
/// triangle pairs, split into the triangles whose centres lie within `margin_mm` of any of
/// `points` (a tumour's), `band`, and the others, `rest`. A triangle whose centre `keep` refuses
/// (outside the organ) is in neither; an empty `keep` keeps all.
void plane_margin_band(const ResectionSurface& plane, const Eigen::Vector3d& centre, double size_mm,
                       int n, const std::vector<Eigen::Vector3d>& points, double margin_mm,
                       const std::function<bool(const Eigen::Vector3d&)>& keep, SurfaceMesh& band,
                       SurfaceMesh& rest);

/// The triangles of F that `take` marks, with their own vertices (renumbered in order).
SurfaceMesh triangle_subset(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                            const std::vector<bool>& take);

/// Where a point is against a resection surface.
struct SideQuery {
  double signed_mm = 0.0;  ///< distance to the surface, > 0 in front
  /// The surface's unit normal where it is nearest (a plane's own): a voxel's half-extent
  /// across the surface is measured along it
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d nearest = Eigen::Vector3d::Zero();  ///< the surface's point nearest it
};

/// Signed distances to a resection surface: exact for a plane; for triangles the distance to
/// the nearest one (CGAL's AABB tree), signed by that triangle's normal. Thread-safe queries.
class SideOf {
 public:
  explicit SideOf(const ResectionSurface& surface);
  ~SideOf();
  SideOf(SideOf&&) noexcept;
  SideOf& operator=(SideOf&&) noexcept;

  SideQuery query(const Eigen::Vector3d& p) const;
  double signed_mm(const Eigen::Vector3d& p) const { return query(p).signed_mm; }
  const ResectionSurface& surface() const { return surface_; }

 private:
  struct Tree;
  ResectionSurface surface_;
  std::unique_ptr<Tree> tree_;  // triangles only
};

}  // namespace lamina::geometry
