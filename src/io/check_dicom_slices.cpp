// A DICOM series as one grid (src/io/header_checks.h). ITK's series reader takes the slice
// spacing from the first two positions and stacks the slices in the order it was given: a
// missing slice (a gap twice the others), two slices at one position, a slice without a
// position (GDCM puts it at 0) or a tilted gantry would all give a volume with the wrong shape,
// without a word.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <numeric>
#include <sstream>
#include <vector>

#include "header_checks.h"
#include "lamina/core/error.h"

namespace lamina::io::detail {
namespace {

// DICOM decimal strings: "a\b\c". Returns false if the count is wrong or a value is not a finite
// number.
bool parse(const std::string& text, size_t count, std::vector<double>& out) {
  out.clear();
  std::istringstream in(text);
  for (std::string t; std::getline(in, t, '\\');) {
    t.erase(0, t.find_first_not_of(' '));
    t.erase(t.find_last_not_of(std::string(" \0", 2)) + 1);
    char* end = nullptr;
    const double v = std::strtod(t.c_str(), &end);
    if (t.empty() || *end != '\0' || !std::isfinite(v)) return false;
    out.push_back(v);
  }
  return out.size() == count;
}

std::string name_of(const std::string& file) {
  return std::filesystem::path(file).filename().string();
}

}  // namespace

DicomGrid check_dicom_slices(const std::string& folder, const std::vector<DicomSliceTags>& slices) {
  if (slices.size() < 2) return {};  // a single slice is refused as 2-D by the caller
  std::vector<double> v;
  std::vector<std::array<double, 3>> position(slices.size());
  std::array<double, 6> orientation{};
  std::array<double, 2> pixel{};
  for (size_t k = 0; k < slices.size(); ++k) {
    const DicomSliceTags& s = slices[k];
    const std::string where = fmt::format("slice {} ({})", k + 1, name_of(s.file));
    // A tag that is absent, or not `count` finite numbers, is refused by name.
    const auto numbers = [&](const std::string& text, size_t count, const char* tag,
                             const char* absent_means) {
      if (text.empty())
        throw invalid_input(folder, fmt::format("{} has no {}{}", where, tag, absent_means));
      if (!parse(text, count, v))
        throw invalid_input(folder, fmt::format("{}: {} '{}' is not {} finite numbers", where, tag,
                                                text.substr(0, 80), count));
      return v;
    };
    const std::vector<double> p = numbers(s.position, 3, "Image Position (Patient) (0020,0032)",
                                          ": the slice's place in the volume is unknown");
    position[k] = {p[0], p[1], p[2]};
    const std::vector<double> ov =
        numbers(s.orientation, 6, "Image Orientation (Patient) (0020,0037)", "");
    std::array<double, 6> o{};
    std::copy(ov.begin(), ov.end(), o.begin());
    numbers(s.pixel_spacing, 2, "Pixel Spacing (0028,0030)", ": the voxel size is unknown");
    if (k == 0) {
      orientation = o;
      pixel = {v[0], v[1]};
      // Pixel Spacing is (row spacing, column spacing): along j, then along i.
      check_spacing(folder, where + ": Pixel Spacing (0028,0030)", {v[1], v[0], 1.0});
      continue;
    }
    for (int n = 0; n < 6; ++n)
      if (std::abs(o[n] - orientation[n]) > 1e-4)
        throw invalid_input(folder, fmt::format("{} has another Image Orientation (Patient) "
                                                "(0020,0037) than slice 1 ('{}' against "
                                                "'{}'): not one volume",
                                                where, s.orientation, slices[0].orientation));
    if (std::abs(v[0] - pixel[0]) > 1e-4 * pixel[0] || std::abs(v[1] - pixel[1]) > 1e-4 * pixel[1])
      throw invalid_input(folder, fmt::format("{} has another Pixel Spacing (0028,0030) than "
                                              "slice 1 ('{}' against '{}')",
                                              where, s.pixel_spacing, slices[0].pixel_spacing));
  }
  const std::array<double, 3> row{orientation[0], orientation[1], orientation[2]};
  const std::array<double, 3> col{orientation[3], orientation[4], orientation[5]};
  const std::array<double, 3> normal{row[1] * col[2] - row[2] * col[1],
                                     row[2] * col[0] - row[0] * col[2],
                                     row[0] * col[1] - row[1] * col[0]};
  check_direction(folder, "Image Orientation (Patient) (0020,0037)", {row, col, normal},
                  /*scaled=*/false);

  // Positions along the normal, in slice order (sorted here: the reader sorts the same way).
  const auto along = [](const std::array<double, 3>& p, const std::array<double, 3>& d) {
    return p[0] * d[0] + p[1] * d[1] + p[2] * d[2];
  };
  std::vector<size_t> order(slices.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return along(position[a], normal) < along(position[b], normal);
  });
  std::vector<double> gaps;
  for (size_t k = 1; k < order.size(); ++k)
    gaps.push_back(along(position[order[k]], normal) - along(position[order[k - 1]], normal));
  std::vector<double> sorted = gaps;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2),
                   sorted.end());
  const double typical = sorted[sorted.size() / 2];
  for (size_t k = 0; k < gaps.size(); ++k) {
    const std::string a = name_of(slices[order[k]].file), b = name_of(slices[order[k + 1]].file);
    if (!(gaps[k] > 1e-3))
      throw invalid_input(folder, fmt::format("two slices lie at the same position ({} and {}, "
                                              "{:.3f} mm apart): a doubled slice or two series "
                                              "in one folder",
                                              a, b, gaps[k]));
    // 1% (and 0.01 mm): scanners write positions to a micrometre; a missing slice is 100% off.
    if (std::abs(gaps[k] - typical) > 0.01 * typical + 0.01)
      throw invalid_input(folder, fmt::format("uneven slice positions: {:.3f} mm between {} and "
                                              "{}, {:.3f} mm between the others (a missing "
                                              "slice?); the volume would be stretched",
                                              gaps[k], a, b, typical));
    // The step from one slice to the next must be along the normal: an in-plane shift is a
    // tilted gantry, a sheared grid.
    std::array<double, 3> step{};
    for (int c = 0; c < 3; ++c) step[c] = position[order[k + 1]][c] - position[order[k]][c];
    const double shift = std::hypot(along(step, row), along(step, col));
    if (shift > 0.01 * typical + 0.01)
      throw invalid_input(folder, fmt::format("slices are shifted in their own plane by {:.3f} mm "
                                              "from {} to {} (a tilted gantry?): a sheared grid, "
                                              "which Lamina does not read; resample it",
                                              shift, a, b));
  }
  DicomGrid grid;
  grid.origin = position[order[0]];
  grid.spacing = {pixel[1], pixel[0], typical};
  grid.axes = {row, col, normal};
  return grid;
}

void check_dicom_grid(const std::string& folder, const DicomGrid& tags,
                      const std::array<double, 3>& spacing, const std::array<double, 3>& origin,
                      const std::array<double, 9>& direction) {
  bool same = true;
  for (int a = 0; a < 3; ++a) {
    same = same && std::abs(spacing[a] - tags.spacing[a]) <= 1e-3 * tags.spacing[a];
    same = same && std::abs(origin[a] - tags.origin[a]) <= 1e-3 * tags.spacing[2] + 1e-3;
    for (int r = 0; r < 3; ++r)
      same = same && std::abs(direction[3 * r + a] - tags.axes[a][r]) <= 1e-4;
  }
  if (!same)
    throw invalid_input(
        folder, fmt::format("the DICOM reader placed the slices at {:g} x {:g} x {:g} mm from "
                            "({:g}, {:g}, {:g}), but their tags say {:g} x {:g} x {:g} mm from "
                            "({:g}, {:g}, {:g}) (a SOP class whose geometry the reader ignores, "
                            "such as Secondary Capture?): export the series as CT or MR images",
                            spacing[0], spacing[1], spacing[2], origin[0], origin[1], origin[2],
                            tags.spacing[0], tags.spacing[1], tags.spacing[2], tags.origin[0],
                            tags.origin[1], tags.origin[2]));
}

}  // namespace lamina::io::detail
