#pragma once
// Synthetic label volumes and masks for tests: spheres and boxes on small grids, shapes given
// by a function.

#include <cmath>
#include <functional>
#include <initializer_list>

#include "lamina/core/grid.h"
#include "lamina/geometry/make_phantom.h"

namespace lamina::test {

/// An all-background volume of n^3 voxels at `spacing` mm.
inline LabelVolume empty_volume(int64_t n, double spacing = 1.0) {
  LabelVolume v;
  v.frame.size = {n, n, n};
  v.frame.spacing_mm = {spacing, spacing, spacing};
  v.frame.origin_mm = {-10.0, 5.0, 2.5};
  v.labels.assign(static_cast<size_t>(n * n * n), 0);
  v.source = "synthetic";
  return v;
}

/// Sets `label` on voxels whose centre is within r mm of c (mm, physical = index*spacing+origin).
inline void paint_sphere(LabelVolume& v, const std::array<double, 3>& c, double r, int32_t label) {
  const auto& f = v.frame;
  for (int64_t k = 0; k < f.size[2]; ++k)
    for (int64_t j = 0; j < f.size[1]; ++j)
      for (int64_t i = 0; i < f.size[0]; ++i) {
        const auto p =
            f.to_physical(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k));
        const double d = std::hypot(p[0] - c[0], p[1] - c[1], p[2] - c[2]);
        if (d <= r) v.labels[f.index(i, j, k)] = label;
      }
}

inline int64_t count_label(const LabelVolume& v, int32_t label) {
  int64_t n = 0;
  for (int32_t l : v.labels) n += l == label;
  return n;
}

/// A mask of `size` voxels of `spacing` mm at the origin: inside where `inside_mm` says so of
/// the voxel's centre (i, j, k times the spacing).
inline Mask mask_where(std::array<int64_t, 3> size, std::array<double, 3> spacing,
                       const std::function<bool(double, double, double)>& inside_mm) {
  Mask m;
  m.frame.size = size;
  m.frame.spacing_mm = spacing;
  m.inside.assign(static_cast<size_t>(m.frame.voxel_count()), 0);
  for (int64_t k = 0; k < size[2]; ++k)
    for (int64_t j = 0; j < size[1]; ++j)
      for (int64_t i = 0; i < size[0]; ++i)
        m.inside[static_cast<size_t>(m.frame.index(i, j, k))] =
            inside_mm(i * spacing[0], j * spacing[1], k * spacing[2]) ? 1 : 0;
  return m;
}

/// The carved-out phantom at 1 mm as an organ (every label but the vena cava, which lies
/// outside it) and a vessel mask of `vessel_labels`: the vessel trees' tests.
struct OrganAndVessels {
  Mask organ, vessels;
};
inline OrganAndVessels phantom_organ_and_vessels(std::initializer_list<int32_t> vessel_labels,
                                                 bool anatomy = false) {
  geometry::PhantomOptions o;
  o.spacing_mm = {1.0, 1.0, 1.0};
  o.carved_out = true;
  o.anatomy = anatomy;
  const LabelVolume v = geometry::make_phantom(o);
  OrganAndVessels p;
  p.organ.frame = p.vessels.frame = v.frame;
  p.organ.inside.resize(v.labels.size());
  p.vessels.inside.resize(v.labels.size());
  for (size_t i = 0; i < v.labels.size(); ++i) {
    const int32_t l = v.labels[i];
    p.organ.inside[i] = l != 0 && l != geometry::kPhantomVenaCava ? 1 : 0;
    p.vessels.inside[i] = 0;
    for (const int32_t w : vessel_labels) p.vessels.inside[i] |= l == w ? 1 : 0;
  }
  return p;
}

}  // namespace lamina::test
