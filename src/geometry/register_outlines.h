#pragma once
// Deformable registration of one shape's outline onto another's on a small cubic grid (internal
// to src/geometry: the Couinaud atlas fits each voting liver to the organ with it).
#include <array>
#include <cstdint>
#include <vector>

namespace lamina::geometry::detail {

/// The signed distance (in voxels, negative inside) to the outline of `inside` (n^3, x fastest,
/// 0 or 1): geometry::signed_distance on a grid of unit spacing (zero on the voxels' faces).
std::vector<float> signed_distance_voxels(const std::vector<uint8_t>& inside, int n);

/// A displacement per voxel (voxels, n^3 each, x fastest): the point p of the fixed shape lies
/// at p + u(p) in the moving one.
struct Displacement {
  std::array<std::vector<float>, 3> u;
};

/// How far the registration goes and how stiff it is (the atlas's validation chose these).
struct RegisterOutlinesOptions {
  int iterations = 40;
  double smooth_voxels = 1.5;  ///< the displacement's Gaussian smoothing after each step
  double band_voxels = 6.0;    ///< only points this near the fixed outline are pushed
  /// With densities (register_outlines_and_densities): the steps after the outline's that also
  /// match the densities inside the fixed shape, and their force's weight against the outline's.
  int density_iterations = 20;
  double density_weight = 4.0;
  double density_depth_voxels = 1.0;  ///< the densities pull points this far inside the outline
};

/// Thirion's demons on the two shapes' signed distances (`fixed`, `moving`: n^3 each, as
/// signed_distance_voxels makes them): every step moves each point near the fixed outline along
/// the moving distance's gradient by the distances' difference, normalised as the demons are, then
/// smooths the displacement (a Gaussian, so the map stays smooth and nearly one to one). The
/// moving distance is read trilinearly, clamped at the grid's edge.
Displacement register_outlines(const std::vector<float>& fixed, const std::vector<float>& moving,
                               int n, const RegisterOutlinesOptions& options = {});

/// register_outlines, then options.density_iterations more steps in which every point deeper than
/// density_depth_voxels inside the fixed shape is also pushed by demons on the two densities
/// (`fixed_density`, `moving_density`: n^3, x fastest, comparable values: the atlas gives each
/// shape's vessel share per voxel, smoothed, over its mean inside the shape), weighted by
/// density_weight. The outline brings the shapes together; the densities then line up what lies
/// inside them (the atlas: the vessels, which run between and through the segments).
Displacement register_outlines_and_densities(const std::vector<float>& fixed,
                                             const std::vector<float>& moving,
                                             const std::vector<float>& fixed_density,
                                             const std::vector<float>& moving_density, int n,
                                             const RegisterOutlinesOptions& options = {});

/// The labels of the moving grid (n^3, x fastest) where the displacement carries each point of
/// the fixed one (the nearest voxel; 0 where it leaves the grid).
std::vector<uint8_t> warp_labels(const std::vector<uint8_t>& moving, const Displacement& d, int n);

}  // namespace lamina::geometry::detail
