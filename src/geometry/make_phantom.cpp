#include "lamina/geometry/make_phantom.h"

#include <algorithm>
#include <cmath>
#include <string>

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

// Distance from p to the segment ab minus the radius: negative inside the capsule.
double capsule(double x, double y, double z, const double a[3], const double b[3], double r) {
  const double ab[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const double ap[3] = {x - a[0], y - a[1], z - a[2]};
  const double t = std::clamp((ap[0] * ab[0] + ap[1] * ab[1] + ap[2] * ab[2]) /
                                  (ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2]),
                              0.0, 1.0);
  const double d[3] = {ap[0] - t * ab[0], ap[1] - t * ab[1], ap[2] - t * ab[2]};
  return std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) - r;
}

// The vessel tree, segment by segment (mm, organ frame): the trunk from below the hilum (it is
// clipped to the organ, so it enters through the visceral surface) to its bifurcation, a branch
// into each lobe, and two more into each lobe's depth.
struct Segment {
  double a[3], b[3], r;
};
constexpr Segment kVessels[] = {
    {{-12, 28, -80}, {-14, 14, -22}, 6.5},  // trunk, through the hilum
    {{-14, 14, -22}, {-55, 8, -8}, 4.5},    // right branch
    {{-14, 14, -22}, {22, 2, -2}, 4.5},     // left branch
    {{-55, 8, -8}, {-88, 2, 10}, 3.0},      // right lobe, lateral
    {{-55, 8, -8}, {-60, 26, -26}, 3.0},    // right lobe, posterior-inferior
    {{22, 2, -2}, {62, -14, 14}, 3.0},      // left lobe, lateral
    {{22, 2, -2}, {38, 18, 14}, 3.0},       // left lobe, posterior
};
constexpr double kTumourCentre[3] = {-60, -18, 32};
constexpr double kTumourRadius = 15.0;

// The carved-out variant's own vessels. The portal trunk continues below the hilum to beyond the
// scan's lower edge. The inferior vena cava runs up the organ's back, to the patient's right of
// the midline, a little forward as it rises: in a groove of the right lobe about a third of its
// width deep where the organ is thickest, clear of it above and below, from edge to edge of the
// scan. Three hepatic veins (right, middle, left) drain into it from the organ's upper part,
// clear of the portal tree and of the tumour by at least 4 mm.
// A second, subcapsular lesion in the left lobe (carved-out variant only): its centre 4 mm under
// the upper surface, so that it bulges 6 mm out of the organ, as LiTS's exophytic tumours do.
constexpr double kLesionCentre[3] = {60, -14, 43.5};
constexpr double kLesionRadius = 10.0;
constexpr Segment kPortalTrunkBelow = {{-11, 36, -140}, {-12, 28, -80}, 6.5};
constexpr Segment kVenaCava = {{-20, 80, -140}, {-16, 58, 150}, 10.0};
constexpr Segment kHepaticVeins[] = {
    {{-17, 64, 36}, {-52, 30, 33}, 5.0},   // right hepatic vein, trunk
    {{-52, 30, 33}, {-88, -2, 28}, 3.5},   //   and its lateral part
    {{-17, 64, 36}, {-30, 10, 22}, 4.5},   // middle hepatic vein, trunk
    {{-30, 10, 22}, {-36, -38, 16}, 3.0},  //   towards the gallbladder fossa
    {{-17, 64, 38}, {10, 30, 38}, 4.5},    // left hepatic vein, trunk
    {{10, 30, 38}, {40, -4, 34}, 3.0},     //   into the left lobe
};

// The wrapped variant (PhantomOptions::wrapped). The vena cava runs 12 mm further forward, into
// the right lobe's back, and a bridge of liver tissue around its axis (19 mm in radius: 9 mm of
// tissue around its 10 mm), from z = -25 to 35 mm, blended into the lobe, closes behind it; the
// flattening against the spine (y < 85) still bounds the organ. So the vena cava passes through
// the organ (a tunnel, open below and above), the three hepatic veins drain into it inside, the
// right one runs on to the lateral surface, and the lesion sits 6 mm higher than the carved
// variant's (its centre 2 mm above the left lobe's upper surface: 12 mm out, 8 mm in).
constexpr Segment kWrappedVenaCava = {{-20, 68, -140}, {-16, 46, 150}, 10.0};
constexpr Segment kCavalBridge = {{-18.41, 59.28, -25.0}, {-17.59, 54.72, 35.0}, 19.0};
constexpr Segment kRightVeinToSurface = {{-88, -2, 28}, {-128, -34, 22}, 3.5};
constexpr double kBulgingLesionCentre[3] = {60, -14, 49.5};

// True when p is inside the capsule; the box test first, since the carved-out grid evaluates
// every voxel against every segment.
bool in_segment(double x, double y, double z, const Segment& s) {
  const double p[3] = {x, y, z};
  for (int a = 0; a < 3; ++a)
    if (p[a] < std::min(s.a[a], s.b[a]) - s.r || p[a] > std::max(s.a[a], s.b[a]) + s.r)
      return false;
  return capsule(x, y, z, s.a, s.b, s.r) < 0.0;
}

}  // namespace

int32_t phantom_anatomy(double x, double y, double z) {
  const double t[3] = {x - kTumourCentre[0], y - kTumourCentre[1], z - kTumourCentre[2]};
  if (t[0] * t[0] + t[1] * t[1] + t[2] * t[2] < kTumourRadius * kTumourRadius)
    return kPhantomTumour;
  for (const Segment& v : kVessels)
    if (capsule(x, y, z, v.a, v.b, v.r) < 0.0) return kPhantomVessel;
  return kPhantomLiver;
}

namespace {

bool in_ball(double x, double y, double z, const double c[3], double r) {
  const double d[3] = {x - c[0], y - c[1], z - c[2]};
  return d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < r * r;
}

// A carved-out variant's structure at a point: both lesions (the subcapsular one at
// `lesion_centre`), the portal tree with its trunk, the hepatic veins (and `extra_vein`, if any),
// the vena cava along `cava`.
int32_t carved_structure(double x, double y, double z, const double lesion_centre[3],
                         const Segment& cava, const Segment* extra_vein) {
  if (in_ball(x, y, z, kTumourCentre, kTumourRadius) ||
      in_ball(x, y, z, lesion_centre, kLesionRadius))
    return kPhantomTumour;
  if (in_segment(x, y, z, kPortalTrunkBelow)) return kPhantomVessel;
  for (const Segment& v : kVessels)
    if (in_segment(x, y, z, v)) return kPhantomVessel;
  for (const Segment& v : kHepaticVeins)
    if (in_segment(x, y, z, v)) return kPhantomHepaticVeins;
  if (extra_vein && in_segment(x, y, z, *extra_vein)) return kPhantomHepaticVeins;
  if (in_segment(x, y, z, cava)) return kPhantomVenaCava;
  return 0;
}

}  // namespace

int32_t phantom_wrapped_structure(double x, double y, double z) {
  return carved_structure(x, y, z, kBulgingLesionCentre, kWrappedVenaCava, &kRightVeinToSurface);
}

int32_t phantom_carved_structure(double x, double y, double z) {
  return carved_structure(x, y, z, kLesionCentre, kVenaCava, nullptr);
}

double phantom_implicit(double x, double y, double z, bool wrapped) {
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
  // The caudate bridge behind the vena cava (the wrapped variant), before the flattening.
  if (wrapped)
    d = smooth_min(d, capsule(x, y, z, kCavalBridge.a, kCavalBridge.b, kCavalBridge.r), 8.0);
  // Diaphragmatic dome stays convex; the posterior surface is flattened against the spine.
  d = smooth_subtract(d, 85.0 - y, 20.0);
  return d;
}

LabelVolume make_phantom(const PhantomOptions& options) {
  LabelVolume v;
  const bool carved = options.carved_out;  // implies the anatomy
  const bool wrapped = options.wrapped;
  v.source = std::string(carved            ? "built-in phantom with carved-out anatomy"
                         : options.anatomy ? "built-in phantom with anatomy"
                                           : "built-in phantom") +
             (wrapped ? ", its vena cava wrapped" : "");
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
    const bool z_in = z >= kLo[2] && z <= kHi[2];
    if (!z_in && !carved) continue;
    for (int64_t j = 0; j < f.size[1]; ++j) {
      const double y = f.origin_mm[1] + static_cast<double>(j) * f.spacing_mm[1];
      const bool y_in = y >= kLo[1] && y <= kHi[1];
      if (!y_in && !carved) continue;
      for (int64_t i = 0; i < f.size[0]; ++i) {
        const double x = f.origin_mm[0] + static_cast<double>(i) * f.spacing_mm[0];
        const bool in_box = z_in && y_in && x >= kLo[0] && x <= kHi[0];
        int32_t& label = v.labels[static_cast<size_t>(f.index(i, j, k))];
        if (carved) {
          // A structure's voxel is the structure's, in the organ or beyond it; the rest of the
          // organ is parenchyma.
          label = wrapped ? phantom_wrapped_structure(x, y, z) : phantom_carved_structure(x, y, z);
          if (label == 0 && in_box && phantom_implicit(x, y, z, wrapped) < 0.0)
            label = kPhantomLiver;
        } else if (in_box && phantom_implicit(x, y, z, wrapped) < 0.0) {
          label = options.anatomy ? phantom_anatomy(x, y, z) : kPhantomLiver;
        }
      }
    }
  }
  return v;
}

}  // namespace lamina::geometry
