#pragma once
// Internal (not installed): converting between our GridFrame and ITK's image geometry. Included
// only by the two ITK translation units, src/io/itk_image_io.cpp and
// src/geometry/itk_mask_filters.cpp.

#include <itkImage.h>

#include "lamina/core/grid.h"

namespace lamina::itk_support {

/// The physical frame of an ITK image (its largest possible region must start at index 0).
template <class Image>
GridFrame frame_of(const Image* image) {
  GridFrame f;
  for (int a = 0; a < 3; ++a) {
    f.size[a] = static_cast<int64_t>(image->GetLargestPossibleRegion().GetSize()[a]);
    f.spacing_mm[a] = image->GetSpacing()[a];
    f.origin_mm[a] = image->GetOrigin()[a];
    for (int c = 0; c < 3; ++c) f.direction[3 * a + c] = image->GetDirection()(a, c);
  }
  return f;
}

/// Sets spacing, origin and direction on anything with ITK's setters (an Image, an
/// ImportImageFilter) and returns the region of the frame's size.
template <class Target>
itk::ImageRegion<3> apply_frame(Target* target, const GridFrame& f) {
  itk::ImageRegion<3> region;
  itk::Vector<double, 3> spacing;
  itk::Point<double, 3> origin;
  itk::Matrix<double, 3, 3> direction;
  for (int a = 0; a < 3; ++a) {
    region.SetSize(a, static_cast<itk::SizeValueType>(f.size[a]));
    spacing[a] = f.spacing_mm[a];
    origin[a] = f.origin_mm[a];
    for (int c = 0; c < 3; ++c) direction(a, c) = f.direction[3 * a + c];
  }
  target->SetSpacing(spacing);
  target->SetOrigin(origin);
  target->SetDirection(direction);
  return region;
}

}  // namespace lamina::itk_support
