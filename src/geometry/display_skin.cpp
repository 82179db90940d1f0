// The display skin and the structures' surfaces: the mask's signed distance on its own grid,
// sampled onto a grid whose spacing gives about the triangle budget, OpenVDB's isosurface there,
// then Taubin smoothing. No remeshing: CGAL's isotropic remeshing of the voxel-resolution
// isosurface took 16 s on a 512 x 512 x 130 mask against a 3 s budget (docs/benchmarks.md);
// this takes about one second, most of it the distance transform.
#include "lamina/geometry/display_skin.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <string>

#include "lamina/core/error.h"
#include "lamina/geometry/extract_isosurface.h"
#include "lamina/geometry/mask_filters.h"
#include "lamina/geometry/mesh_measures.h"
#include "lamina/geometry/prepare_mask.h"
#include "lamina/geometry/smooth_surface.h"
#include "sample_grid.h"

namespace lamina::geometry {
namespace {

// `fine` sampled on a grid of cubic cells `h_mm` wide over the same box, one cell wider on
// every side so that the surface closes inside it whatever h is.
DistanceField resample(const DistanceField& fine, double h_mm) {
  DistanceField out;
  out.frame = fine.frame;
  const auto& sp = fine.frame.spacing_mm;
  double step[3];
  for (int a = 0; a < 3; ++a) {
    out.frame.spacing_mm[a] = h_mm;
    step[a] = h_mm / sp[a];  // fine voxels a coarse cell
    out.frame.size[a] =
        static_cast<int64_t>(std::ceil(static_cast<double>(fine.frame.size[a] - 1) / step[a])) + 3;
  }
  const auto o = fine.frame.to_physical(-step[0], -step[1], -step[2]);
  out.frame.origin_mm = {o[0], o[1], o[2]};
  out.phi.resize(static_cast<size_t>(out.frame.voxel_count()));
  const auto& n = out.frame.size;
#pragma omp parallel for schedule(static)
  for (int64_t k = 0; k < n[2]; ++k)
    for (int64_t j = 0; j < n[1]; ++j)
      for (int64_t i = 0; i < n[0]; ++i)
        // Clamped: points beyond the fine grid take its border's values, which are outside
        // (positive) on a padded mask.
        out.phi[static_cast<size_t>(out.frame.index(i, j, k))] = detail::sample_trilinear(
            fine.phi.data(), fine.frame.size, static_cast<double>(i - 1) * step[0],
            static_cast<double>(j - 1) * step[1], static_cast<double>(k - 1) * step[2]);
  return out;
}

// Moves every vertex along its normal (the area-weighted mean of its faces') by one distance so
// that the surface encloses `target_mm3`: volume changes by about area x distance, corrected
// three times. The isosurface of a thin vessel (a voxel or two across) and its smoothing leave
// it up to 9% smaller than its voxels (TotalSegmentator's portal vein at 3 mm); a segmentation's
// volume is its voxels', and so is what a planner reads from the surface. Each step is capped at
// a quarter voxel, so a surface far off (a piece dropped by largest_only) is not inflated.
void match_volume(SurfaceMesh& s, double target_mm3, double cap_mm) {
  for (int round = 0; round < 3; ++round) {
    double area = 0.0;
    for (Eigen::Index f = 0; f < s.F.rows(); ++f)
      area += 0.5 * (s.V.row(s.F(f, 1)) - s.V.row(s.F(f, 0)))
                        .cross(s.V.row(s.F(f, 2)) - s.V.row(s.F(f, 0)))
                        .norm();
    if (area <= 0.0) return;
    const double d = std::clamp((target_mm3 - enclosed_volume(s)) / area, -cap_mm, cap_mm);
    if (std::abs(d) < 1e-6) return;
    Eigen::MatrixX3d n = Eigen::MatrixX3d::Zero(s.V.rows(), 3);
    for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
      const Eigen::RowVector3d a = s.V.row(s.F(f, 0)), b = s.V.row(s.F(f, 1)),
                               c = s.V.row(s.F(f, 2));
      const Eigen::RowVector3d area_normal = (b - a).cross(c - a);  // twice the area, outward
      for (int k = 0; k < 3; ++k) n.row(s.F(f, k)) += area_normal;
    }
    for (Eigen::Index v = 0; v < s.V.rows(); ++v) {
      const double len = n.row(v).norm();
      if (len > 0.0) s.V.row(v) += (d / len) * n.row(v);
    }
  }
}

SurfaceMesh budget_surface(const Mask& mask, int64_t triangles, bool largest_only,
                           const std::string& what) {
  if (triangles < 100)
    throw invalid_input(
        what, "the triangle budget must be at least 100, got " + std::to_string(triangles));
  const double area = mask_boundary_area_mm2(mask);
  if (area <= 0.0) throw invalid_input(what, "the mask has no surface");
  // No finer than the voxels. The organ's skin: about one triangle per voxel-sized patch of
  // surface (the voxel's mean size, the cube root of its volume), beyond which a budget adds
  // triangles, not detail. A structure (a vessel a few voxels wide) keeps cells down to one
  // voxel: three triangles a patch.
  const double voxel_mm = std::cbrt(mask.frame.voxel_volume_mm3());
  const double per_patch = largest_only ? 1.0 : 3.0;
  triangles = std::min<int64_t>(
      triangles,
      std::max<int64_t>(100, static_cast<int64_t>(per_patch * area / (voxel_mm * voxel_mm))));
  // Two voxels of background around it: the distance is exact up to the border.
  const DistanceField fine = signed_distance(pad_mask(mask, 2));
  const double coarsest =
      *std::max_element(mask.frame.spacing_mm.begin(), mask.frame.spacing_mm.end());
  // A dual-contouring isosurface has about 3 triangles per h^2 of surface (measured on the
  // phantom and TotalSegmentator's liver); the count is then corrected from the one achieved.
  double h = std::sqrt(3.0 * area / static_cast<double>(triangles));
  SurfaceMesh surface;
  for (int round = 0; round < 4; ++round) {
    surface = extract_isosurface(resample(fine, h), 0.0);
    if (largest_only) surface = largest_piece(surface);
    const double ratio = static_cast<double>(surface.F.rows()) / static_cast<double>(triangles);
    if (surface.F.rows() == 0 || std::abs(ratio - 1.0) <= 0.03) break;
    h *= std::sqrt(ratio);
  }
  if (surface.F.rows() == 0) throw invalid_input(what, "the mask has no surface");
  // The staircase of the voxels is up to one (largest) voxel deep; its wavelength in edges
  // grows as h shrinks below it, and a diffusion reaches sqrt(iterations) edges: so about
  // 5 (coarsest / h)^2 pairs, at least 5 for the dual contour's own wiggles.
  const double r = coarsest / h;
  taubin_smooth(surface, std::clamp(static_cast<int>(std::ceil(5.0 * r * r)), 5, 60));
  int64_t voxels = 0;
  for (const uint8_t b : mask.inside) voxels += b != 0;
  match_volume(surface, static_cast<double>(voxels) * mask.frame.voxel_volume_mm3(),
               0.25 * voxel_mm);
  return surface;
}

}  // namespace

SurfaceMesh display_skin(const Mask& mask, int64_t triangles) {
  return budget_surface(mask, triangles, true, "--display-triangles");
}

SurfaceMesh structure_surface(const Mask& mask, int64_t triangles, const std::string& name) {
  return budget_surface(mask, triangles, false, name);
}

}  // namespace lamina::geometry
