// The display skin: the same pipeline as the simulation's skin (signed distance, OpenVDB's
// isosurface, CGAL's remeshing), but on the mask's own grid and to a triangle budget rather than
// a vertex count, so that it follows the segmentation to under a voxel.
#include "lamina/geometry/display_skin.h"

#include <algorithm>
#include <cmath>

#include "lamina/core/error.h"
#include "lamina/geometry/extract_isosurface.h"
#include "lamina/geometry/mask_filters.h"
#include "lamina/geometry/mesh_measures.h"
#include "lamina/geometry/prepare_mask.h"
#include "lamina/geometry/remesh.h"

namespace lamina::geometry {
namespace {

// The edge of near-equilateral triangles that tile `area_mm2` in `triangles` (each
// sqrt(3)/4 L^2); CGAL's remeshing keeps edges between 4/5 and 4/3 of its target, so the count
// is then corrected once from the one achieved.
double edge_for_triangles(double area_mm2, double triangles) {
  return std::sqrt(4.0 * area_mm2 / (std::sqrt(3.0) * triangles));
}

}  // namespace

SurfaceMesh display_skin(const Mask& mask, int64_t triangles) {
  if (triangles < 100)
    throw invalid_input("--display-triangles",
                        "must be at least 100, got " + std::to_string(triangles));
  // Two voxels of background around it: the isosurface closes inside the grid.
  const DistanceField sdf = signed_distance(pad_mask(mask, 2));
  // No adaptivity: merging flat polygons first (OpenVDB's 0.3) made the 100k-triangle skin 1.6x
  // slower on the 1.5 mm phantom (splitting them again costs the remesher more) and its volume
  // error 0.8% instead of 0.06%.
  SurfaceMesh raw = extract_isosurface(sdf, 0.0);
  if (raw.F.rows() == 0) throw invalid_input("display skin", "the mask has no surface");
  std::vector<SurfaceMesh> parts = split_components(raw);
  if (parts.size() > 1) {
    std::sort(parts.begin(), parts.end(), [](const SurfaceMesh& a, const SurfaceMesh& b) {
      return enclosed_volume(a) > enclosed_volume(b);
    });
    raw = parts.front();
  }
  const double area = measure_mesh(raw).area_mm2;
  double edge = edge_for_triangles(area, static_cast<double>(triangles));
  SurfaceMesh skin = remesh(raw, {.target_edge_mm = edge});
  const double ratio = static_cast<double>(skin.F.rows()) / static_cast<double>(triangles);
  if (std::abs(ratio - 1.0) > 0.05) {
    edge *= std::sqrt(ratio);
    skin = remesh(raw, {.target_edge_mm = edge});
  }
  return skin;
}

}  // namespace lamina::geometry
