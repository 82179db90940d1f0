#include "lamina/geometry/prepare_mask.h"

#include <algorithm>
#include <set>
#include <sstream>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/geometry/mask_filters.h"

namespace lamina::geometry {
namespace {

std::string present_labels(const std::vector<int32_t>& labels) {
  std::set<int32_t> seen;
  for (int32_t l : labels) {
    if (l != 0) seen.insert(l);
    if (seen.size() > 12) break;
  }
  if (seen.empty()) return "none: the image is all background";
  std::ostringstream s;
  int n = 0;
  for (int32_t l : seen) s << (n++ ? ", " : "") << l;
  if (seen.size() > 12) s << ", ...";
  return s.str();
}

// Copies the box [lo, hi] of `in` into a grid with `pad` extra voxels on every side.
Mask crop_and_pad(const GridFrame& in_frame, const std::vector<uint8_t>& in,
                  const std::array<int64_t, 3>& lo, const std::array<int64_t, 3>& hi, int pad) {
  Mask out;
  out.frame = in_frame;
  for (int a = 0; a < 3; ++a) out.frame.size[a] = hi[a] - lo[a] + 1 + 2 * pad;
  out.frame.origin_mm =
      in_frame.to_physical(static_cast<double>(lo[0] - pad), static_cast<double>(lo[1] - pad),
                           static_cast<double>(lo[2] - pad));
  out.inside.assign(static_cast<size_t>(out.frame.voxel_count()), 0);
  const int64_t nx = hi[0] - lo[0] + 1;
#pragma omp parallel for schedule(static)
  for (int64_t k = lo[2]; k <= hi[2]; ++k)
    for (int64_t j = lo[1]; j <= hi[1]; ++j) {
      const uint8_t* src = in.data() + in_frame.index(lo[0], j, k);
      uint8_t* dst = out.inside.data() + out.frame.index(pad, j - lo[1] + pad, k - lo[2] + pad);
      std::copy(src, src + nx, dst);
    }
  return out;
}

}  // namespace

Mask pad_mask(const Mask& mask, int pad) {
  std::array<int64_t, 3> lo{0, 0, 0}, hi{};
  for (int a = 0; a < 3; ++a) hi[a] = mask.frame.size[a] - 1;
  return crop_and_pad(mask.frame, mask.inside, lo, hi, pad);
}

PreparedMask prepare_mask(const LabelVolume& volume, const MaskOptions& options) {
  const GridFrame& f = volume.frame;
  const std::string& name = volume.source.empty() ? std::string("input") : volume.source;
  if (static_cast<int64_t>(volume.labels.size()) != f.voxel_count())
    throw invalid_input(name, "label buffer does not match the image size");

  // Select the label(s), note which of the listed ones are present, and find the bounding box,
  // in one pass.
  std::vector<uint8_t> listed_present(options.labels.size(), 0);
  const auto selects = [&](int32_t l) {
    if (!options.labels.empty()) {
      const auto at = std::find(options.labels.begin(), options.labels.end(), l);
      if (at == options.labels.end()) return false;
      listed_present[static_cast<size_t>(at - options.labels.begin())] = 1;
      return true;
    }
    return options.label == 0 ? l != 0 : l == options.label;
  };
  std::vector<uint8_t> selected(volume.labels.size());
  std::array<int64_t, 3> lo{f.size[0], f.size[1], f.size[2]}, hi{-1, -1, -1};
  int64_t count = 0;
  for (int64_t k = 0; k < f.size[2]; ++k)
    for (int64_t j = 0; j < f.size[1]; ++j) {
      const int64_t row = f.index(0, j, k);
      int64_t row_lo = -1, row_hi = -1;
      for (int64_t i = 0; i < f.size[0]; ++i) {
        const int32_t l = volume.labels[static_cast<size_t>(row + i)];
        const bool in = l != 0 && selects(l);
        selected[static_cast<size_t>(row + i)] = in;
        if (in) {
          if (row_lo < 0) row_lo = i;
          row_hi = i;
          ++count;
        }
      }
      if (row_lo >= 0) {
        lo = {std::min(lo[0], row_lo), std::min(lo[1], j), std::min(lo[2], k)};
        hi = {std::max(hi[0], row_hi), std::max(hi[1], j), std::max(hi[2], k)};
      }
    }
  for (size_t k = 0; k < options.labels.size(); ++k)
    if (!listed_present[k])
      throw invalid_input(name, "label " + std::to_string(options.labels[k]) +
                                    " is absent (labels present: " + present_labels(volume.labels) +
                                    ")");
  if (count == 0) {
    if (options.label != 0)
      throw invalid_input(name, "label " + std::to_string(options.label) +
                                    " is absent (labels present: " + present_labels(volume.labels) +
                                    "); pick one with --label");
    throw invalid_input(name, "the mask is empty: no voxel is non-zero");
  }

  PreparedMask out;
  MaskReport& r = out.report;
  if (options.structures) {
    if (options.structures->size() != volume.labels.size())
      throw invalid_input(name, "the structures' buffer does not match the image size");
    r.structures =
        add_enclosed_structures(f, selected, *options.structures, options.structure_count,
                                options.whole_structures, lo, hi);
    if (r.structures.organ_own == 0)
      throw invalid_input(name,
                          "every voxel selected as the organ is an embedded structure's; the "
                          "organ needs a label of its own (name it with --label)");
    count += r.structures.added;
    // A tumour taken whole can reach beyond the organ's own box.
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], r.structures.added_lo[a]);
      hi[a] = std::max(hi[a], r.structures.added_hi[a]);
    }
  }
  r.label = options.label;
  r.selected_voxels = count;
  for (int a = 0; a < 3; ++a) r.touches_scan_border |= lo[a] == 0 || hi[a] == f.size[a] - 1;

  out.mask = crop_and_pad(f, selected, lo, hi, std::max(1, options.pad_voxels));
  selected = {};
  const ComponentStats cc =
      options.clean ? keep_largest_component(out.mask) : ComponentStats{1, count, 0};
  r.components = cc.components;
  r.dropped_voxels = cc.dropped_voxels;
  r.cavity_voxels_filled = options.clean ? fill_cavities(out.mask) : 0;
  r.kept_voxels = cc.kept_voxels + r.cavity_voxels_filled;
  r.kept_volume_ml = static_cast<double>(r.kept_voxels) * f.voxel_volume_mm3() / 1000.0;

  if (r.kept_voxels < options.min_voxels)
    throw invalid_input(name, "the organ has only " + std::to_string(r.kept_voxels) +
                                  " voxel(s); at least " + std::to_string(options.min_voxels) +
                                  " are needed to build a closed surface");
  if (cc.components > 1)
    log::warn("{}: kept the largest of {} components ({} voxels); dropped {} voxels ({:.2f} mL)",
              name, cc.components, cc.kept_voxels, cc.dropped_voxels,
              static_cast<double>(cc.dropped_voxels) * f.voxel_volume_mm3() / 1000.0);
  if (r.cavity_voxels_filled > 0)
    log::info("{}: filled {} cavity voxels", name, r.cavity_voxels_filled);
  if (r.touches_scan_border && options.clean)  // a structure (not clean) may leave the scan
    log::info("{}: the organ touches the scan border; padded so its surface closes", name);
  return out;
}

double mask_boundary_area_mm2(const Mask& mask) {
  const auto& f = mask.frame;
  const double face[3] = {f.spacing_mm[1] * f.spacing_mm[2], f.spacing_mm[0] * f.spacing_mm[2],
                          f.spacing_mm[0] * f.spacing_mm[1]};
  const int64_t stride[3] = {1, f.size[0], f.size[0] * f.size[1]};
  double area = 0.0;
  for (int64_t k = 0; k < f.size[2]; ++k)
    for (int64_t j = 0; j < f.size[1]; ++j)
      for (int64_t i = 0; i < f.size[0]; ++i) {
        const int64_t v = f.index(i, j, k);
        const int64_t at[3] = {i, j, k};
        for (int a = 0; a < 3; ++a) {
          // The face below voxel v along axis a: between it and its neighbour there, or, on the
          // grid's first slice, between it and the background beyond; and the last slice's top.
          const bool in = mask.inside[static_cast<size_t>(v)] != 0;
          const bool below = at[a] > 0 && mask.inside[static_cast<size_t>(v - stride[a])] != 0;
          if (in != below) area += face[a];
          if (in && at[a] == f.size[a] - 1) area += face[a];
        }
      }
  return area / 1.5;
}

}  // namespace lamina::geometry
