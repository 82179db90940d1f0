#pragma once
// The compiled-in Couinaud atlas's livers (couinaud_atlas.cpp), for the tests that check the
// atlas against itself.
#include <cstdint>

namespace lamina::geometry::detail {

/// One liver of the compiled-in atlas (couinaud_atlas.cpp): its labels 0-8 on a g^3 grid in its
/// own bounding box (x to the patient's left, y to the back, z up; z fastest, then y, x).
struct AtlasLiver {
  int g = 0;
  int lits_number = 0;
  const uint8_t* labels = nullptr;
  /// Its vessels' share of each bin's voxels x 255 (same layout), or null when not known.
  const uint8_t* vessels = nullptr;
};
int atlas_liver_count();
AtlasLiver atlas_liver(int index);

}  // namespace lamina::geometry::detail
