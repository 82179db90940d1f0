// The only geometry translation unit that sees ITK (see core/grid.h for why it is isolated).
#include <itkBinShrinkImageFilter.h>
#include <itkConnectedComponentImageFilter.h>
#include <itkConnectedThresholdImageFilter.h>
#include <itkImportImageFilter.h>

#include <algorithm>
#include <cmath>

#include "core/itk_frame.h"
#include "distance_transform.h"
#include "lamina/core/error.h"
#include "lamina/geometry/mask_filters.h"
#include "lamina/geometry/prepare_mask.h"

namespace lamina::geometry {
namespace {

using itk_support::frame_of;
using MaskImage = itk::Image<uint8_t, 3>;

// Wraps our buffer as an ITK image without copying (ITK does not own the memory).
template <class Pixel>
typename itk::Image<Pixel, 3>::Pointer wrap(const GridFrame& f, const Pixel* data) {
  using Import = itk::ImportImageFilter<Pixel, 3>;
  auto import = Import::New();
  import->SetRegion(itk_support::apply_frame(import.GetPointer(), f));
  import->SetImportPointer(const_cast<Pixel*>(data),
                           static_cast<itk::SizeValueType>(f.voxel_count()), false);
  import->Update();
  typename itk::Image<Pixel, 3>::Pointer image = import->GetOutput();
  image->DisconnectPipeline();
  return image;
}

template <class Filter>
void update(Filter* filter, const char* what) {
  try {
    filter->Update();
  } catch (const itk::ExceptionObject& e) {
    throw Error(ErrorKind::kInternal, std::string(what) + " failed: " + e.GetDescription());
  }
}

}  // namespace

ComponentStats keep_largest_component(Mask& mask) {
  using LabelImage = itk::Image<uint32_t, 3>;
  auto input = wrap<uint8_t>(mask.frame, mask.inside.data());
  auto cc = itk::ConnectedComponentImageFilter<MaskImage, LabelImage>::New();
  cc->SetInput(input);
  cc->SetFullyConnected(false);  // face neighbours: a diagonal touch does not join two organs
  cc->SetBackgroundValue(0);
  update(cc.GetPointer(), "connected components");

  ComponentStats stats;
  stats.components = static_cast<int32_t>(cc->GetObjectCount());
  const uint32_t* labels = cc->GetOutput()->GetBufferPointer();
  const size_t n = mask.inside.size();
  std::vector<int64_t> sizes(static_cast<size_t>(stats.components) + 1, 0);
  for (size_t v = 0; v < n; ++v) ++sizes[labels[v]];
  uint32_t best = 0;
  for (uint32_t l = 1; l < sizes.size(); ++l)
    if (best == 0 || sizes[l] > sizes[best]) best = l;
  for (size_t v = 0; v < n; ++v) mask.inside[v] = (best != 0 && labels[v] == best) ? 1 : 0;
  stats.kept_voxels = best ? sizes[best] : 0;
  for (uint32_t l = 1; l < sizes.size(); ++l)
    if (l != best) stats.dropped_voxels += sizes[l];
  return stats;
}

int32_t label_components(const Mask& mask, bool fully_connected, std::vector<int32_t>& labels) {
  using LabelImage = itk::Image<int32_t, 3>;
  auto input = wrap<uint8_t>(mask.frame, mask.inside.data());
  auto cc = itk::ConnectedComponentImageFilter<MaskImage, LabelImage>::New();
  cc->SetInput(input);
  cc->SetFullyConnected(fully_connected);
  cc->SetBackgroundValue(0);
  update(cc.GetPointer(), "connected components");
  const int32_t* out = cc->GetOutput()->GetBufferPointer();
  labels.assign(out, out + mask.inside.size());
  return static_cast<int32_t>(cc->GetObjectCount());
}

int64_t fill_cavities(Mask& mask) {
  // Flood the background from a corner; whatever background it cannot reach is a cavity.
  auto input = wrap<uint8_t>(mask.frame, mask.inside.data());
  auto flood = itk::ConnectedThresholdImageFilter<MaskImage, MaskImage>::New();
  flood->SetInput(input);
  flood->SetLower(0);
  flood->SetUpper(0);
  flood->SetReplaceValue(1);
  flood->SetConnectivity(decltype(flood)::ObjectType::FaceConnectivity);
  MaskImage::IndexType corner;
  corner.Fill(0);
  if (mask.inside[0] != 0) return 0;  // unpadded mask touching the corner: nothing to flood from
  flood->AddSeed(corner);
  update(flood.GetPointer(), "cavity filling");
  const uint8_t* outside = flood->GetOutput()->GetBufferPointer();
  int64_t filled = 0;
  for (size_t v = 0; v < mask.inside.size(); ++v) {
    if (!mask.inside[v] && !outside[v]) {
      mask.inside[v] = 1;
      ++filled;
    }
  }
  return filled;
}

Mask downsample_mask(const Mask& mask, const std::array<int, 3>& factors) {
  if (factors[0] == 1 && factors[1] == 1 && factors[2] == 1) return mask;
  using RealImage = itk::Image<float, 3>;
  auto input = wrap<uint8_t>(mask.frame, mask.inside.data());
  auto shrink = itk::BinShrinkImageFilter<MaskImage, RealImage>::New();
  shrink->SetInput(input);
  for (int a = 0; a < 3; ++a)
    shrink->SetShrinkFactor(a, static_cast<unsigned>(std::max(1, factors[a])));
  update(shrink.GetPointer(), "downsampling");
  Mask out;
  out.frame = frame_of(shrink->GetOutput());
  // BinShrink may keep a non-zero start index; our frames always start at index 0.
  const auto start = shrink->GetOutput()->GetLargestPossibleRegion().GetIndex();
  const auto p0 = out.frame.to_physical(start[0], start[1], start[2]);
  out.frame.origin_mm = p0;
  const float* occ = shrink->GetOutput()->GetBufferPointer();
  out.inside.resize(static_cast<size_t>(out.frame.voxel_count()));
  for (size_t v = 0; v < out.inside.size(); ++v) out.inside[v] = occ[v] >= 0.5f ? 1 : 0;
  return out;
}

std::vector<float> distance_to_mask(const Mask& mask) {
  return detail::distance_to_foreground(mask.frame, mask.inside);
}

Mask close_mask(const Mask& mask, double radius_mm) {
  // On a grid padded by the ball: beyond the mask's grid is background, and a dilation that
  // reached its edge would find no background left to erode from. A closing never leaves the
  // mask's convex hull, so what it adds lies on the mask's own grid.
  const auto& s = mask.frame.spacing_mm;
  const int pad = 2 + static_cast<int>(std::ceil(radius_mm / std::min({s[0], s[1], s[2]})));
  const Mask padded = pad_mask(mask, pad);
  // A voxel is in the dilation when a mask voxel lies within the radius; in the closing when no
  // voxel outside the dilation does.
  const std::vector<float> to_mask = detail::distance_to_foreground(padded.frame, padded.inside);
  const float r = static_cast<float>(radius_mm);
  std::vector<uint8_t> outside_dilation(padded.inside.size());
  for (size_t v = 0; v < to_mask.size(); ++v) outside_dilation[v] = to_mask[v] > r ? 1 : 0;
  const std::vector<float> to_outside =
      detail::distance_to_foreground(padded.frame, outside_dilation);
  Mask out;
  out.frame = mask.frame;
  out.inside.resize(mask.inside.size());
  const GridFrame &f = mask.frame, &g = padded.frame;
  for (int64_t k = 0; k < f.size[2]; ++k)
    for (int64_t j = 0; j < f.size[1]; ++j)
      for (int64_t i = 0; i < f.size[0]; ++i) {
        const size_t v = static_cast<size_t>(f.index(i, j, k));
        const size_t w = static_cast<size_t>(g.index(i + pad, j + pad, k + pad));
        out.inside[v] = (mask.inside[v] || (!outside_dilation[w] && to_outside[w] > r)) ? 1 : 0;
      }
  return out;
}

DistanceField signed_distance(const Mask& mask) {
  // Two one-sided transforms rather than one signed one: ITK's signed map measures inside
  // distances to a fully connected contour (voxels that touch the background only diagonally
  // count), which makes depths up to a voxel too shallow; measuring from each side to the
  // other side's voxel centres is exact and symmetric.
  std::vector<uint8_t> outside(mask.inside.size());
  for (size_t v = 0; v < outside.size(); ++v) outside[v] = mask.inside[v] ? 0 : 1;
  const std::vector<float> d_out = detail::distance_to_foreground(mask.frame, mask.inside);
  std::vector<float> d_in = detail::distance_to_foreground(mask.frame, outside);
  // Voxel centres are half a voxel from the boundary between them: shifting both sides by half
  // a voxel (geometric mean of the spacing) puts the zero level on the voxel faces.
  const auto& s = mask.frame.spacing_mm;
  const float half = static_cast<float>(0.5 * std::cbrt(s[0] * s[1] * s[2]));
  DistanceField field;
  field.frame = mask.frame;
  field.phi = std::move(d_in);
  for (size_t v = 0; v < field.phi.size(); ++v)
    field.phi[v] = mask.inside[v] ? -(field.phi[v] - half) : d_out[v] - half;
  return field;
}

}  // namespace lamina::geometry
