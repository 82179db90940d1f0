// The raw NIfTI-1 header, field by field (src/io/header_checks.h). The NIfTI library inside ITK
// repairs what it does not like instead of refusing it: pixdim 0 or NaN becomes 1 mm, a negative
// pixdim its absolute value, a vox_offset inside the header 352, a NaN scl_slope "no scaling", a
// quaternion longer than 1 a normalised one, and a non-orthogonal sform is dropped for the qform.
// Every one of those is refused here, before ITK reads the file.
#include <fmt/format.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>

#include "header_checks.h"
#include "lamina/core/error.h"

namespace lamina::io::detail {
namespace {

namespace fs = std::filesystem;

constexpr int kHeaderBytes = 348;
constexpr int kNifti2HeaderBytes = 540;

// Reads the header's fields in either byte order.
class RawHeader {
 public:
  explicit RawHeader(const unsigned char* bytes) : b_(bytes) {}
  void set_swapped(bool s) { swapped_ = s; }
  int32_t i32(int at) const { return static_cast<int32_t>(load<uint32_t>(at)); }
  int16_t i16(int at) const { return static_cast<int16_t>(load<uint16_t>(at)); }
  double f32(int at) const {
    const uint32_t u = load<uint32_t>(at);
    float f;
    std::memcpy(&f, &u, 4);
    return f;
  }

 private:
  template <class U>
  U load(int at) const {
    U u;
    std::memcpy(&u, b_ + at, sizeof(U));
    if (swapped_) {
      U r = 0;
      for (size_t k = 0; k < sizeof(U); ++k) r = static_cast<U>((r << 8) | ((u >> (8 * k)) & 0xff));
      u = r;
    }
    return u;
  }
  const unsigned char* b_;
  bool swapped_ = false;
};

// Byte offsets of the NIfTI-1 fields used here (nifti1.h).
enum : int {
  kSizeofHdr = 0,
  kDim = 40,
  kDatatype = 70,
  kBitpix = 72,
  kPixdim = 76,
  kVoxOffset = 108,
  kSclSlope = 112,
  kSclInter = 116,
  kQformCode = 252,
  kSformCode = 254,
  kQuatern = 256,
  kQoffset = 268,
  kSrow = 280,
  kMagic = 344,
};

// Bits per voxel of the scalar types a label mask can be stored in; 0 for any other type.
int scalar_bits(int datatype) {
  switch (datatype) {
    case 2:
    case 256:
      return 8;  // uint8, int8
    case 4:
    case 512:
      return 16;  // int16, uint16
    case 8:
    case 768:
    case 16:
      return 32;  // int32, uint32, float32
    case 64:
    case 1024:
    case 1280:
      return 64;  // float64, int64, uint64
    default:
      return 0;
  }
}

using Columns = std::array<std::array<double, 3>, 3>;

// The qform's rotation (nifti1.h: quaternion b, c, d with a = sqrt(1 - b^2 - c^2 - d^2)), its
// third column flipped by qfac, each column scaled by pixdim.
Columns qform_columns(double b, double c, double d, double qfac, const std::array<double, 3>& s) {
  const double a = std::sqrt(std::max(0.0, 1.0 - (b * b + c * c + d * d)));
  const double R[3][3] = {
      {a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c)},
      {2 * (b * c + a * d), a * a + c * c - b * b - d * d, 2 * (c * d - a * b)},
      {2 * (b * d - a * c), 2 * (c * d + a * b), a * a + d * d - c * c - b * b}};
  Columns cols;
  for (int col = 0; col < 3; ++col)
    for (int row = 0; row < 3; ++row)
      cols[col][row] = R[row][col] * s[col] * (col == 2 && qfac < 0 ? -1.0 : 1.0);
  return cols;
}

double norm(const std::array<double, 3>& v) {
  return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

}  // namespace

void check_nifti_header(const std::string& path, int64_t max_voxels) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  const bool pair = ext == ".hdr" || ext == ".img";
  const std::string header_path =
      ext == ".img" ? fs::path(path).replace_extension(".hdr").string() : path;
  std::array<unsigned char, kHeaderBytes> bytes{};
  gzFile f = gzopen(header_path.c_str(), "rb");
  if (!f) throw invalid_input(header_path, "cannot open the file");
  const int got = gzread(f, bytes.data(), kHeaderBytes);
  gzclose(f);
  if (got < kHeaderBytes)
    throw invalid_input(header_path, fmt::format("is truncated: a NIfTI-1 header is {} bytes, the "
                                                 "file holds {}",
                                                 kHeaderBytes, std::max(got, 0)));
  RawHeader h(bytes.data());
  if (h.i32(kSizeofHdr) != kHeaderBytes) {
    h.set_swapped(true);
    if (h.i32(kSizeofHdr) != kHeaderBytes) {
      h.set_swapped(false);
      const bool nifti2 = h.i32(kSizeofHdr) == kNifti2HeaderBytes ||
                          (h.set_swapped(true), h.i32(kSizeofHdr) == kNifti2HeaderBytes);
      if (nifti2)
        throw invalid_input(header_path,
                            "is NIfTI-2, which Lamina's reader (ITK 5.2) does not "
                            "read: save the mask as NIfTI-1 (.nii.gz)");
      throw invalid_input(header_path, "is not a NIfTI-1 file (sizeof_hdr is not 348)");
    }
  }
  const std::string magic(reinterpret_cast<const char*>(bytes.data() + kMagic), 3);
  if (magic != "n+1" && magic != "ni1")
    throw invalid_input(header_path,
                        "has no NIfTI magic (an Analyze 7.5 header, whose "
                        "orientation is undefined): convert it to NIfTI-1");

  // Sizes and type.
  const int rank = h.i16(kDim);
  if (rank < 1 || rank > 7)
    throw invalid_input(header_path, fmt::format("dim[0] (the number of dimensions) must be 1..7, "
                                                 "got {}",
                                                 rank));
  uint64_t voxels = 1;
  for (int d = 1; d <= rank; ++d) {
    const int n = h.i16(kDim + 2 * d);
    if (n < 1)
      throw invalid_input(header_path, fmt::format("dim[{}] must be at least 1, got {}", d, n));
    voxels = saturating_product(voxels, static_cast<uint64_t>(n));
  }
  const int datatype = h.i16(kDatatype), bitpix = h.i16(kBitpix);
  const int bits = scalar_bits(datatype);
  if (bits == 0)
    throw invalid_input(header_path, fmt::format("datatype {} is not a scalar type a label mask "
                                                 "can be stored in (use uint8 or int16)",
                                                 datatype));
  if (bitpix != bits)
    throw invalid_input(header_path, fmt::format("bitpix {} does not match datatype {} ({} bits "
                                                 "per voxel)",
                                                 bitpix, datatype, bits));

  // Voxel size: the headline repair (ITK reads 0 or NaN as 1 mm, and -1 as 1).
  std::array<double, 3> spacing{};
  for (int a = 0; a < 3; ++a) spacing[a] = a < rank ? h.f32(kPixdim + 4 * (a + 1)) : 1.0;
  check_spacing(header_path, "pixdim[1..3] (voxel size)", spacing);

  // Where the data starts, and how its values are scaled.
  const double vox_offset = h.f32(kVoxOffset);
  if (!std::isfinite(vox_offset) || vox_offset < 0.0 || (!pair && vox_offset < 352.0) ||
      vox_offset != std::floor(vox_offset) || vox_offset > 1e15)
    throw invalid_input(header_path, fmt::format("vox_offset {:g} is not where voxel data can "
                                                 "start (a whole number, at least 352 in a .nii "
                                                 "file)",
                                                 vox_offset));
  const double slope = h.f32(kSclSlope), inter = h.f32(kSclInter);
  if (!std::isfinite(slope) || !std::isfinite(inter))
    throw invalid_input(header_path, fmt::format("scl_slope {:g} / scl_inter {:g} is not finite "
                                                 "(a reader would ignore it)",
                                                 slope, inter));
  if (slope != 0.0 && (slope != 1.0 || inter != 0.0))
    throw invalid_input(header_path, fmt::format("scl_slope {:g} / scl_inter {:g} rescales the "
                                                 "voxels, which would turn labels into other "
                                                 "numbers: store the mask unscaled (scl_slope 1, "
                                                 "scl_inter 0)",
                                                 slope, inter));

  // Orientation. Codes beyond NIFTI_XFORM_TEMPLATE_OTHER (5) mean nothing; the library would
  // still use the transform.
  const int qcode = h.i16(kQformCode), scode = h.i16(kSformCode);
  for (const auto& [name, code] : {std::pair{"qform_code", qcode}, std::pair{"sform_code", scode}})
    if (code < 0 || code > 5)
      throw invalid_input(header_path,
                          fmt::format("{} {} is not a NIfTI transform code (0..5)", name, code));
  Columns q{}, s{};
  std::array<double, 3> q_origin{}, s_origin{};
  if (qcode > 0) {
    const double b = h.f32(kQuatern), c = h.f32(kQuatern + 4), d = h.f32(kQuatern + 8);
    const double qfac = h.f32(kPixdim);
    if (!std::isfinite(b) || !std::isfinite(c) || !std::isfinite(d))
      throw invalid_input(header_path, fmt::format("the qform quaternion (quatern_b, c, d) is not "
                                                   "finite: {:g}, {:g}, {:g}",
                                                   b, c, d));
    if (b * b + c * c + d * d > 1.0 + 1e-4)
      throw invalid_input(header_path, fmt::format("the qform quaternion (quatern_b, c, d = {:g}, "
                                                   "{:g}, {:g}) is longer than 1, so it is not a "
                                                   "rotation (a reader would rescale it)",
                                                   b, c, d));
    if (qfac != 1.0 && qfac != -1.0 && qfac != 0.0)
      throw invalid_input(header_path,
                          fmt::format("pixdim[0] (qfac) must be 1 or -1, got {:g}", qfac));
    for (int a = 0; a < 3; ++a) q_origin[a] = h.f32(kQoffset + 4 * a);
    check_origin(header_path, "qoffset_x/y/z (qform origin)", q_origin);
    q = qform_columns(b, c, d, qfac, spacing);
  }
  if (scode > 0) {
    for (int row = 0; row < 3; ++row) {
      for (int col = 0; col < 3; ++col) s[col][row] = h.f32(kSrow + 16 * row + 4 * col);
      s_origin[row] = h.f32(kSrow + 16 * row + 12);
    }
    check_direction(header_path, "the sform (srow_x/y/z)", s, /*scaled=*/true);
    check_origin(header_path, "the sform's origin (srow_x/y/z[3])", s_origin);
    // ITK takes the voxel size from pixdim and only the direction from the sform: two sizes
    // would be mixed silently.
    for (int a = 0; a < 3; ++a)
      if (std::abs(norm(s[a]) - spacing[a]) > 1e-3 * spacing[a])
        throw invalid_input(
            header_path,
            fmt::format("the sform's voxel size ({:g} x {:g} x {:g} mm) disagrees with pixdim "
                        "({:g} x {:g} x {:g} mm): which is right is not known",
                        norm(s[0]), norm(s[1]), norm(s[2]), spacing[0], spacing[1], spacing[2]));
  }
  if (qcode > 0 && scode > 0) {
    // Both set: they must describe the same grid, or the reader's choice decides the organ's
    // place and orientation.
    double worst = 0.0;
    for (int a = 0; a < 3; ++a)
      for (int r = 0; r < 3; ++r) worst = std::max(worst, std::abs(q[a][r] - s[a][r]) / spacing[a]);
    double shift = 0.0;
    for (int r = 0; r < 3; ++r) shift = std::max(shift, std::abs(q_origin[r] - s_origin[r]));
    const double smallest = std::min({spacing[0], spacing[1], spacing[2]});
    if (worst > 1e-3 || shift > 1e-3 * smallest + 1e-4)
      throw invalid_input(header_path,
                          fmt::format("the qform and the sform describe different grids "
                                      "(directions differ by up to {:.3g}, origins by {:.3g} mm): "
                                      "set one of qform_code, sform_code to 0 or make them agree",
                                      worst, shift));
  }

  // The data the header describes must all be there (ITK would leave the missing voxels zero:
  // half a liver would build silently).
  if (voxels > static_cast<uint64_t>(max_voxels)) return;
  const uint64_t data = saturating_product(voxels, static_cast<uint64_t>(bits / 8));
  if (pair) {
    const std::string image_path = fs::path(header_path).replace_extension(".img").string();
    const uint64_t held = count_data_bytes(image_path, 0, /*gzip=*/false);
    const uint64_t expected = static_cast<uint64_t>(vox_offset) + data;
    if (held < expected)
      throw invalid_input(image_path, fmt::format("is truncated: the header describes {} bytes "
                                                  "but the file holds {}",
                                                  expected, held));
    return;
  }
  const uint64_t expected = static_cast<uint64_t>(vox_offset) + data;
  const uint64_t held = count_data_bytes(path, 0, /*gzip=*/true);
  if (held < expected)
    throw invalid_input(path, fmt::format("is truncated: the header describes {} bytes but the "
                                          "file holds {}",
                                          expected, held));
}

}  // namespace lamina::io::detail
