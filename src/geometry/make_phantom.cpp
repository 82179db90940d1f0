#include "lamina/geometry/make_phantom.h"

#include <algorithm>
#include <cmath>

#include "lamina/core/error.h"

namespace lamina::geometry {
namespace {

// Ellipsoid distance bound (Quilez): exact on the surface, a close estimate near it.
double ellipsoid(double x, double y, double z, double cx, double cy, double cz, double rx,
                 double ry, double rz) {
  const double qx = (x - cx) / rx, qy = (y - cy) / ry, qz = (z - cz) / rz;
  const double k0 = std::sqrt(qx * qx + qy * qy + qz * qz);
  const double k1 = std::sqrt(qx * qx / (rx * rx) + qy * qy / (ry * ry) + qz * qz / (rz * rz));
  return k1 > 0.0 ? k0 * (k0 - 1.0) / k1 : -std::min({rx, ry, rz});
}

// Polynomial smooth minimum: blends two shapes over a band of width k (mm).
double smooth_min(double a, double b, double k) {
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - h * h * k * 0.25;
}
double smooth_subtract(double a, double b, double k) {
  return -smooth_min(-a, b, k);
}

// Organ bounding box in its own frame (mm), with a little slack; checked by a test.
constexpr double kLo[3] = {-125.0, -66.0, -63.0};
constexpr double kHi[3] = {120.0, 80.0, 70.0};

}  // namespace

double phantom_implicit(double x, double y, double z) {
  // Right lobe: the bulk of the liver, on the patient's right (x < 0), tall and deep.
  const double right = ellipsoid(x, y, z, -45, 8, 0, 76, 70, 66);
  // Left lobe: thinner and flatter, reaching across the midline, raised towards the heart.
  const double left = ellipsoid(x, y, z, 48, -12, 18, 68, 46, 30);
  double d = smooth_min(right, left, 30.0);
  // Visceral (inferior) surface: flattened from below...
  d = smooth_subtract(d, ellipsoid(x, y, z, -10, 30, -102, 105, 85, 55), 14.0);
  // ...and hollowed where the kidney and duodenum press into it, so the underside is concave.
  d = smooth_subtract(d, ellipsoid(x, y, z, -48, 22, -88, 40, 36, 58), 10.0);
  // Gallbladder fossa: a groove on the anterior underside of the right lobe.
  d = smooth_subtract(d, ellipsoid(x, y, z, -22, -50, -40, 14, 30, 14), 6.0);
  // Diaphragmatic dome stays convex; the posterior surface is flattened against the spine.
  d = smooth_subtract(d, 85.0 - y, 20.0);
  return d;
}

LabelVolume make_phantom(const PhantomOptions& options) {
  LabelVolume v;
  v.source = "built-in phantom";
  GridFrame& f = v.frame;
  f.spacing_mm = options.spacing_mm;
  for (int a = 0; a < 3; ++a) {
    if (!(options.spacing_mm[a] > 0.0) || !std::isfinite(options.spacing_mm[a]))
      throw invalid_input("--spacing", "voxel spacing must be positive");
    const double extent = kHi[a] - kLo[a] + 12.0;  // 6 mm margin each side
    f.size[a] = options.size[a] > 0
                    ? options.size[a]
                    : static_cast<int64_t>(std::ceil(extent / options.spacing_mm[a])) + 1;
    if (f.size[a] < 2) throw invalid_input("--size", "each grid dimension must be at least 2");
    // Centre the organ's box in the grid.
    const double centre = 0.5 * (kLo[a] + kHi[a]);
    f.origin_mm[a] = centre - 0.5 * static_cast<double>(f.size[a] - 1) * f.spacing_mm[a];
  }
  if (f.voxel_count() > (int64_t{1} << 31))
    throw invalid_input("--size", "grid of " + std::to_string(f.voxel_count()) +
                                      " voxels is too large (limit 2^31)");
  v.labels.assign(static_cast<size_t>(f.voxel_count()), 0);
#pragma omp parallel for schedule(dynamic, 1)
  for (int64_t k = 0; k < f.size[2]; ++k) {
    const double z = f.origin_mm[2] + static_cast<double>(k) * f.spacing_mm[2];
    if (z < kLo[2] || z > kHi[2]) continue;
    for (int64_t j = 0; j < f.size[1]; ++j) {
      const double y = f.origin_mm[1] + static_cast<double>(j) * f.spacing_mm[1];
      if (y < kLo[1] || y > kHi[1]) continue;
      for (int64_t i = 0; i < f.size[0]; ++i) {
        const double x = f.origin_mm[0] + static_cast<double>(i) * f.spacing_mm[0];
        if (x < kLo[0] || x > kHi[0]) continue;
        if (phantom_implicit(x, y, z) < 0.0) v.labels[static_cast<size_t>(f.index(i, j, k))] = 1;
      }
    }
  }
  return v;
}

}  // namespace lamina::geometry
