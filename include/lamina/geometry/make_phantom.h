#pragma once
/// \file
/// The built-in phantom: a procedurally generated, liver-like binary mask, so that a fresh
/// machine needs no patient data.

#include <array>
#include <cstdint>

#include "lamina/core/grid.h"

namespace lamina::geometry {

/// Options for make_phantom(). The organ has a fixed adult-liver size (about 1.7 L, roughly
/// 235 x 135 x 125 mm); spacing and grid size only change how it is sampled.
struct PhantomOptions {
  std::array<double, 3> spacing_mm{1.5, 1.5, 1.5};  ///< voxel size, mm, > 0
  /// Grid size in voxels; {0,0,0} = just large enough for the organ plus a 6 mm margin. A grid
  /// smaller than the organ crops it (the organ then touches the scan edge, as in real scans).
  std::array<int64_t, 3> size{0, 0, 0};
};

/// Samples the liver-like phantom: a large right lobe and a thinner left lobe blended
/// smoothly, a concave visceral (inferior) surface and a gallbladder fossa; not convex, not a
/// sphere. Label 1 inside, 0 outside; physical frame LPS (x to the patient's left, y posterior,
/// z superior), identity direction, the organ centred in the grid.
/// @param[in] options  spacing and grid size
/// @return the label volume, source "built-in phantom"
LabelVolume make_phantom(const PhantomOptions& options = {});

/// Signed implicit function of the phantom at a point (mm, organ frame): negative inside.
/// Not an exact distance, but Lipschitz-bounded near the surface.
double phantom_implicit(double x, double y, double z);

}  // namespace lamina::geometry
