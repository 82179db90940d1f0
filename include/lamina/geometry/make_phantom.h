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
  /// Also the anatomy inside the organ, each a label of its own (kPhantomVessel,
  /// kPhantomTumour); the organ is their union with kPhantomLiver, the same voxels either way.
  bool anatomy = false;
  /// The anatomy (implies `anatomy`) in the layout most multi-label liver segmentations are stored
  /// in (IRCAD, the Decathlon's hepatic-vessel task, 3D Slicer labelmaps), each voxel liver *or* a
  /// structure, with the vessels as they are in a patient: the portal vein's trunk leaves the
  /// organ through the hilum and runs on to the scan's lower edge, hepatic veins
  /// (kPhantomHepaticVeins) drain into the inferior vena cava (kPhantomVenaCava), which lies in
  /// a groove of the organ's back and runs from the scan's lower edge to its upper one; a second
  /// tumour (10 mm radius) lies under the left lobe's upper surface and bulges 6 mm out. Label 1
  /// is the parenchyma alone; the organ (the voxels of the phantom without anatomy) is label 1
  /// with the structures' parts inside it.
  bool carved_out = false;
  /// The vena cava wrapped by the liver, as the caudate lobe wraps it in most patients: a bridge
  /// of liver tissue closes behind it over 60 mm, so that with `carved_out` the vena cava and the
  /// hepatic veins draining into it inside the bridge are tunnels through the organ's label, not
  /// a groove; the right hepatic vein runs on to the organ's lateral surface (another tunnel),
  /// and the subcapsular lesion bulges 12 mm out. Without `carved_out` it changes only the
  /// organ's shape (the whole-organ segmentation of the same patient).
  bool wrapped = false;
};

/// The phantom's labels with `anatomy` (lamina phantom --labels; docs/cli.md).
inline constexpr int32_t kPhantomLiver = 1;   ///< the parenchyma
inline constexpr int32_t kPhantomVessel = 2;  ///< a portal-vein-like tree entering at the hilum
inline constexpr int32_t kPhantomTumour = 3;  ///< a 15 mm-radius tumour in the right lobe
inline constexpr int32_t kPhantomHepaticVeins = 4;  ///< carved_out: three veins to the vena cava
inline constexpr int32_t kPhantomVenaCava = 5;      ///< carved_out: mostly outside the organ

/// Samples the liver-like phantom: a large right lobe and a thinner left lobe blended
/// smoothly, a concave visceral (inferior) surface and a gallbladder fossa; not convex, not a
/// sphere. Label 1 inside, 0 outside; physical frame LPS (x to the patient's left, y posterior,
/// z superior), identity direction, the organ centred in the grid.
/// @param[in] options  spacing and grid size
/// @return the label volume, source "built-in phantom"
LabelVolume make_phantom(const PhantomOptions& options = {});

/// The anatomy's label at a point of the organ (mm, organ frame): kPhantomTumour,
/// kPhantomVessel or kPhantomLiver. The vessel tree runs from the hilum on the visceral
/// (inferior) surface up into both lobes in three generations (radii 6.5, 4.5 and 3 mm); the
/// tumour lies in the right lobe, clear of the tree and of the surface.
int32_t phantom_anatomy(double x, double y, double z);

/// The carved-out variant's structure at a point (mm, organ frame), inside the organ or not:
/// kPhantomTumour (both lesions), kPhantomVessel (its trunk unclipped), kPhantomHepaticVeins,
/// kPhantomVenaCava, or 0 for none.
int32_t phantom_carved_structure(double x, double y, double z);

/// The wrapped variant's structure at a point (mm, organ frame), as phantom_carved_structure().
int32_t phantom_wrapped_structure(double x, double y, double z);

/// Signed implicit function of the phantom at a point (mm, organ frame): negative inside.
/// Not an exact distance, but Lipschitz-bounded near the surface. `wrapped`: with the bridge of
/// caudate tissue behind the vena cava (PhantomOptions::wrapped).
double phantom_implicit(double x, double y, double z, bool wrapped = false);

}  // namespace lamina::geometry
