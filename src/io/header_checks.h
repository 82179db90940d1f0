#pragma once
// Internal (not installed): checks of a volume file's own header, made before a reader library
// sees it. ITK repairs some broken values without a word (a zero or NaN NIfTI pixdim becomes
// 1 mm, a negative one its absolute value, a non-orthonormal sform is swapped for the qform, an
// absent NRRD or MetaImage spacing becomes 1 mm, a DICOM slice without a position sits at 0), and
// the organ built from the repaired grid has the wrong size or shape. So each format's header is
// read here, raw, and refused with one line naming the file, the field and the value
// (docs/errors.md, "Volume headers").

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace lamina::io::detail {

/// Each of the three voxel sizes is finite and > 0 (mm). `field` names the header field as the
/// format does ("pixdim[1..3]", "ElementSpacing").
void check_spacing(const std::string& path, const std::string& field,
                   const std::array<double, 3>& spacing);

/// `columns[c]` is the physical direction of index axis c. With `scaled`, each column's length
/// is that axis's voxel size (a NIfTI sform, NRRD space directions), which must then be finite
/// and > 0; otherwise each must be a unit vector. Either way the columns must be finite,
/// independent (not singular) and orthogonal, within 1e-3: Lamina's grid is a rotated box.
void check_direction(const std::string& path, const std::string& field,
                     const std::array<std::array<double, 3>, 3>& columns, bool scaled);

/// Each coordinate finite (mm).
void check_origin(const std::string& path, const std::string& field,
                  const std::array<double, 3>& origin);

/// In the three checks below, the data's size is not counted when the header describes more
/// than `max_voxels` voxels: the caller refuses those with the voxel limit's own message.
///
/// The raw header of a NIfTI-1 file (.nii, .nii.gz, or an .hdr/.img pair): sizes, data type,
/// pixdim, vox_offset, scaling, qform and sform (their codes, values, agreement with each other
/// and with pixdim), and that the data the header describes is all there.
void check_nifti_header(const std::string& path, int64_t max_voxels);

/// The raw header of a NRRD file: sizes, spacing (space directions or spacings, present, finite,
/// positive), direction, origin, space units (mm), and the data's size for raw and gzip data.
void check_nrrd_header(const std::string& path, int64_t max_voxels);

/// The raw header of a MetaImage file (.mha/.mhd): key syntax and lengths (ITK's MetaIO aborts
/// on some corrupt headers), sizes, ElementSpacing, TransformMatrix, Offset, and the size of
/// uncompressed data.
void check_metaimage_header(const std::string& path, int64_t max_voxels);

/// What the geometry of one DICOM slice says, as the tags' text; empty = tag absent.
struct DicomSliceTags {
  std::string file;
  std::string position;       ///< Image Position (Patient), (0020,0032): x\y\z
  std::string orientation;    ///< Image Orientation (Patient), (0020,0037): row\column cosines
  std::string pixel_spacing;  ///< Pixel Spacing, (0028,0030): row spacing\column spacing
};

/// The grid a DICOM series' own tags describe.
struct DicomGrid {
  std::array<double, 3> origin{};   ///< position of the first slice along the normal, mm
  std::array<double, 3> spacing{};  ///< along the rows (i), the columns (j), the normal (k), mm
  std::array<std::array<double, 3>, 3> axes{};  ///< unit direction of i, j, k
};

/// A DICOM series as one grid: every slice has a position, an orientation and a pixel spacing,
/// the same orientation and spacing throughout, and positions evenly spaced along the slice
/// normal with no in-plane shift (no missing, doubled or tilted slices).
/// @return the grid the tags describe, for the caller to hold the reader's grid against
DicomGrid check_dicom_slices(const std::string& folder, const std::vector<DicomSliceTags>& slices);

/// The reader's grid (`spacing`, `origin`, row-major `direction` as GridFrame holds them) must
/// be the one the tags describe: GDCM does not take the geometry of every SOP class from its
/// tags.
void check_dicom_grid(const std::string& folder, const DicomGrid& tags,
                      const std::array<double, 3>& spacing, const std::array<double, 3>& origin,
                      const std::array<double, 9>& direction);

/// a * b, or UINT64_MAX when that overflows (a corrupt header's sizes can multiply past 2^64).
inline uint64_t saturating_product(uint64_t a, uint64_t b) {
  return b != 0 && a > UINT64_MAX / b ? UINT64_MAX : a * b;
}

/// Bytes of a file from `offset` on, inflated when `gzip` (a truncated or corrupt stream is an
/// error naming the file). Counts without keeping the data.
uint64_t count_data_bytes(const std::string& path, uint64_t offset, bool gzip);

}  // namespace lamina::io::detail
