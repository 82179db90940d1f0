// The geometry every format's header must describe: a box of voxels, rotated, not sheared
// (src/io/header_checks.h).
#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>
#include <zlib.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <vector>

#include "header_checks.h"
#include "lamina/core/error.h"

namespace lamina::io::detail {
namespace {

// Orthogonality within about 0.06 degrees: float32 headers (NIfTI) and DICOM's decimal strings
// carry ~1e-6, an oblique scan is exactly orthogonal, and a sheared grid is off by far more.
constexpr double kTolerance = 1e-3;

std::string triple(const std::array<double, 3>& v) {
  return fmt::format("{:g} x {:g} x {:g}", v[0], v[1], v[2]);
}

std::string vector_text(const std::array<double, 3>& v) {
  return fmt::format("({:g}, {:g}, {:g})", v[0], v[1], v[2]);
}

double dot(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

}  // namespace

void check_spacing(const std::string& path, const std::string& field,
                   const std::array<double, 3>& spacing) {
  for (double s : spacing)
    if (!std::isfinite(s) || !(s > 0.0))
      throw invalid_input(path, fmt::format("{} must be three positive voxel sizes in mm, got {} "
                                            "(a reader would guess 1 mm or drop the sign; fix the "
                                            "header)",
                                            field, triple(spacing)));
}

void check_direction(const std::string& path, const std::string& field,
                     const std::array<std::array<double, 3>, 3>& columns, bool scaled) {
  const std::string all = fmt::format("{} {} {}", vector_text(columns[0]), vector_text(columns[1]),
                                      vector_text(columns[2]));
  for (const auto& c : columns)
    for (double v : c)
      if (!std::isfinite(v)) throw invalid_input(path, field + " is not finite: " + all);
  std::array<std::array<double, 3>, 3> unit = columns;
  for (int a = 0; a < 3; ++a) {
    const double length = std::sqrt(dot(columns[a], columns[a]));
    if (!(length > 0.0))
      throw invalid_input(path, fmt::format("{} gives index axis {} no length (a zero voxel "
                                            "size): {}",
                                            field, a, all));
    if (!scaled && std::abs(length - 1.0) > kTolerance)
      throw invalid_input(path, fmt::format("{} is not a rotation: axis {} has length {:g}, not "
                                            "1: {}",
                                            field, a, length, all));
    for (double& v : unit[a]) v /= length;
  }
  const auto& u = unit;
  const double det = u[0][0] * (u[1][1] * u[2][2] - u[1][2] * u[2][1]) -
                     u[1][0] * (u[0][1] * u[2][2] - u[0][2] * u[2][1]) +
                     u[2][0] * (u[0][1] * u[1][2] - u[0][2] * u[1][1]);
  if (std::abs(det) < kTolerance)
    throw invalid_input(path, fmt::format("{} is singular (its axes are not independent, "
                                          "determinant {:.3g}): {}",
                                          field, det, all));
  for (int a = 0; a < 3; ++a)
    for (int b = a + 1; b < 3; ++b)
      if (std::abs(dot(u[a], u[b])) > kTolerance)
        throw invalid_input(
            path, fmt::format("{} is not orthogonal: axes {} and {} meet at {:.2f} degrees, not "
                              "90 (a sheared grid, which Lamina does not read; resample it): {}",
                              field, a, b, std::acos(dot(u[a], u[b])) * 180.0 / M_PI, all));
}

void check_origin(const std::string& path, const std::string& field,
                  const std::array<double, 3>& origin) {
  for (double v : origin)
    if (!std::isfinite(v))
      throw invalid_input(path, fmt::format("{} is not finite: {}", field, vector_text(origin)));
}

uint64_t count_data_bytes(const std::string& path, uint64_t offset, bool gzip) {
  if (!gzip) {
    std::error_code ec;
    const uint64_t size = std::filesystem::file_size(path, ec);
    if (ec) throw invalid_input(path, "cannot read the file: " + ec.message());
    return size > offset ? size - offset : 0;
  }
  // The stream may start `offset` bytes into the file (NRRD and MetaImage put it after a text
  // header): skip those on the descriptor and hand the rest to zlib, which also reads a plain
  // (uncompressed) remainder as it is.
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) throw invalid_input(path, "cannot open the file");
  if (::lseek(fd, static_cast<off_t>(offset), SEEK_SET) < 0) {
    ::close(fd);
    throw invalid_input(path, "cannot read the file");
  }
  gzFile f = gzdopen(fd, "rb");
  if (!f) {
    ::close(fd);
    throw invalid_input(path, "cannot open the file");
  }
  std::vector<char> buf(1 << 20);
  uint64_t total = 0;
  int n = 0;
  while ((n = gzread(f, buf.data(), static_cast<unsigned>(buf.size()))) > 0)
    total += static_cast<uint64_t>(n);
  int err = Z_OK;
  std::string msg = gzerror(f, &err);  // copied: the text dies with gzclose
  gzclose(f);                          // closes fd too
  if (msg.rfind("<fd:", 0) == 0) msg.erase(0, msg.find(": ") + 2);  // zlib names the descriptor
  if (n < 0 || (err != Z_OK && err != Z_STREAM_END))
    throw invalid_input(path, "the compressed data is corrupt or truncated (" + msg + ")");
  return total;
}

}  // namespace lamina::io::detail
