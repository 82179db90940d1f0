#pragma once
/// \file
/// Reading and writing segmentations in physical space, through ITK.

#include <cstdint>
#include <string>

#include "lamina/core/grid.h"

namespace lamina::io {

/// Options for read_label_volume().
struct ReadVolumeOptions {
  /// Refuse images with more voxels than this before allocating anything (a corrupt header can
  /// claim terabytes). 2^31 voxels is 8 GiB of int32 labels.
  int64_t max_voxels = int64_t{1} << 31;
};

/// Reads a 3-D label image: NIfTI (.nii, .nii.gz), NRRD (.nrrd, .seg.nrrd), MetaImage
/// (.mha, .mhd), or a folder holding one DICOM series.
/// @param[in] path  file or DICOM folder
/// @return the labels with spacing, origin and direction as ITK reports them (mm, patient LPS)
/// \note Integer pixels are kept as they are; floating-point pixels are rounded to the nearest
///   integer label (non-finite values are an error). Throws lamina::Error (kInvalidInput) with a
///   one-line message naming `path` for a missing, unreadable, truncated, 2-D, multi-component or
///   non-positive-spacing image.
LabelVolume read_label_volume(const std::string& path, const ReadVolumeOptions& options = {});

/// Writes a label volume (uint8 if all labels fit, else int32) in the format the extension
/// names (.nii, .nii.gz, .nrrd, .mha, .mhd), atomically (temporary file, then rename).
void write_label_volume(const LabelVolume& volume, const std::string& path);

}  // namespace lamina::io
