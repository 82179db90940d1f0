// Couinaud's segments placed by an atlas (couinaud_segments.h): the expert labels of 111 LiTS
// livers (data/couinaud_atlas.bin, compiled in), each binned in its own bounding box. The
// livers whose shape in the box is most like this organ's, each moved by the few bins that
// fit it best and then bent onto the organ's outline (demons: register_outlines.h) and, when
// the organ's vessels are given, their vessels onto its (only the 17 livers whose vessels are
// known then vote), vote for every bin; the votes smoothed and interpolated give every voxel its
// segment. Multi-atlas label fusion (Heckemann et al. 2006; Rohlfing et al. 2004): measured
// against 3D-IRCADb-01's experts (none of whose livers is in the atlas), mean Dice 0.805 with
// the vessels, 0.798 without, where the box and shift alone gave 0.789 and the experts' mean
// planes in the box 0.735 (docs/resection.md).
#include <zlib.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include "couinaud_internal.h"
#include "lamina/core/error.h"
#include "lamina/geometry/couinaud_segments.h"
#include "register_outlines.h"
#include "sample_grid.h"
#include "smooth_grid.h"
#include "vessel_internal.h"

extern const unsigned char lamina_couinaud_atlas[];
extern const std::size_t lamina_couinaud_atlas_size;

namespace lamina::geometry {
namespace {

// The livers that vote, how far (bins) each may move to fit, and the votes' smoothing (bins):
// chosen on the validation of docs/resection.md (before the bending, 10 livers: 0.793; 20:
// 0.781; all 111: 0.756; bent, 20 gained 0.002 for twice the time).
constexpr int kVoters = 10;
constexpr int kShiftBins = 3;
constexpr double kSmoothBins = 1.0;
constexpr int kPadBins = 4;
// The vessels' shares per bin are smoothed by this much (bins) before they are matched.
constexpr double kVesselSmoothBins = 1.0;

struct Atlas {
  int g = 0;                      // bins along each axis (40)
  std::vector<uint16_t> numbers;  // each liver's LiTS number
  std::vector<uint8_t> labels;    // per liver g^3 labels 0-8, z fastest, then y, then x
  std::vector<uint64_t> bits;     // per liver g^2 columns: its bins as z bits (occupancy)
  std::vector<int64_t> bins;      // per liver: how many bins it fills
  std::vector<int> vessel_slot;   // per liver: its vessels' grid in `vessels`, -1 if not known
  std::vector<uint8_t> vessels;   // per liver with vessels: g^3 vessel shares x 255
};

// A liver's bins as bits: one 64-bit word of z bits per (x, y) column.
void add_occupancy(const uint8_t* labels, int g, std::vector<uint64_t>& bits) {
  for (int c = 0; c < g * g; ++c) {
    uint64_t w = 0;
    for (int z = 0; z < g; ++z)
      if (labels[static_cast<size_t>(c * g + z)] != 0) w |= 1ULL << z;
    bits.push_back(w);
  }
}

int64_t count_bits(const uint64_t* bits, int g) {
  int64_t n = 0;
  for (int c = 0; c < g * g; ++c) n += std::popcount(bits[c]);
  return n;
}

Atlas inflate_atlas() {
  std::vector<uint8_t> raw;
  z_stream z{};
  if (inflateInit(&z) != Z_OK) throw Error(ErrorKind::kInternal, "Couinaud atlas: zlib failed");
  z.next_in = const_cast<Bytef*>(lamina_couinaud_atlas);
  z.avail_in = static_cast<uInt>(lamina_couinaud_atlas_size);
  std::array<uint8_t, 1 << 16> chunk{};
  int rc = Z_OK;
  while (rc == Z_OK) {
    z.next_out = chunk.data();
    z.avail_out = chunk.size();
    rc = inflate(&z, Z_NO_FLUSH);
    raw.insert(raw.end(), chunk.data(), chunk.data() + (chunk.size() - z.avail_out));
  }
  inflateEnd(&z);
  Atlas a;
  uint32_t header[2] = {0, 0};
  const auto damaged = [] {
    return Error(ErrorKind::kInternal, "Couinaud atlas: the compiled-in data is damaged");
  };
  if (rc != Z_STREAM_END || raw.size() < 12 || std::memcmp(raw.data(), "LCA2", 4) != 0)
    throw damaged();
  std::memcpy(header, raw.data() + 4, sizeof header);
  a.g = static_cast<int>(header[0]);
  const size_t n = header[1], cells = size_t{header[0]} * header[0] * header[0];
  size_t at = 12 + 2 * n + n * cells;  // the vessels' part
  if (a.g < 8 || a.g > 64 || raw.size() < at + 4) throw damaged();
  a.numbers.resize(n);
  std::memcpy(a.numbers.data(), raw.data() + 12, 2 * n);
  a.labels.assign(raw.begin() + static_cast<std::ptrdiff_t>(12 + 2 * n),
                  raw.begin() + static_cast<std::ptrdiff_t>(at));
  uint32_t with_vessels = 0;
  std::memcpy(&with_vessels, raw.data() + at, 4);
  at += 4;
  if (with_vessels > n || raw.size() != at + size_t{with_vessels} * (2 + cells)) throw damaged();
  a.vessel_slot.assign(n, -1);
  for (uint32_t k = 0; k < with_vessels; ++k) {
    uint16_t liver = 0;
    std::memcpy(&liver, raw.data() + at + 2 * k, 2);
    if (liver >= n) throw damaged();
    a.vessel_slot[liver] = static_cast<int>(k);
  }
  at += 2 * size_t{with_vessels};
  a.vessels.assign(raw.begin() + static_cast<std::ptrdiff_t>(at), raw.end());
  // The livers' shapes, which every organ is fitted against, made once.
  for (size_t l = 0; l < n; ++l) {
    add_occupancy(a.labels.data() + l * cells, a.g, a.bits);
    a.bins.push_back(count_bits(a.bits.data() + l * size_t{header[0]} * header[0], a.g));
  }
  return a;
}

const Atlas& atlas() {
  static const Atlas a = inflate_atlas();  // once per process, on first use (thread-safe)
  return a;
}

struct Fit {
  double overlap = -1.0;  // Dice of the two shapes in the box, with the shift
  std::array<int, 3> shift{};
  int liver = 0;
};

// The shift of a liver's bins (within kShiftBins each way) that overlaps the organ's most.
Fit best_shift(const std::vector<uint64_t>& organ, int64_t organ_bins, const uint64_t* liver,
               int64_t liver_bins, int g) {
  const uint64_t all = g == 64 ? ~0ULL : (1ULL << g) - 1;
  Fit best;
  for (int dx = -kShiftBins; dx <= kShiftBins; ++dx)
    for (int dy = -kShiftBins; dy <= kShiftBins; ++dy)
      for (int dz = -kShiftBins; dz <= kShiftBins; ++dz) {
        int64_t both = 0;
        for (int x = std::max(0, dx); x < std::min(g, g + dx); ++x)
          for (int y = std::max(0, dy); y < std::min(g, g + dy); ++y) {
            const uint64_t w = liver[static_cast<size_t>((x - dx) * g + (y - dy))];
            const uint64_t moved = dz >= 0 ? (w << dz) & all : w >> -dz;
            both += std::popcount(moved & organ[static_cast<size_t>(x * g + y)]);
          }
        const double dice =
            2.0 * static_cast<double>(both) / static_cast<double>(organ_bins + liver_bins);
        if (dice > best.overlap) best = {dice, {dx, dy, dz}, 0};
      }
  return best;
}

}  // namespace

namespace detail {
int atlas_liver_count() {
  return static_cast<int>(atlas().numbers.size());
}
AtlasLiver atlas_liver(int index) {
  const Atlas& a = atlas();
  const size_t cells = static_cast<size_t>(a.g) * a.g * a.g;
  const int slot = a.vessel_slot.at(static_cast<size_t>(index));
  return {a.g, a.numbers.at(static_cast<size_t>(index)),
          a.labels.data() + static_cast<size_t>(index) * cells,
          slot < 0 ? nullptr : a.vessels.data() + static_cast<size_t>(slot) * cells};
}
}  // namespace detail

namespace {

// A vessel share per bin (n^3, x fastest) made comparable between livers whose vessels were
// segmented more or less finely: smoothed, then divided by its mean over the liver's own bins.
void normalise_density(std::vector<float>& density, const std::vector<uint8_t>& inside, int n) {
  std::vector<float> scratch;
  detail::smooth_grid(density, {n, n, n}, detail::gaussian_kernel(kVesselSmoothBins), scratch);
  double sum = 0.0;
  int64_t count = 0;
  for (size_t i = 0; i < density.size(); ++i)
    if (inside[i] != 0) {
      sum += density[i];
      ++count;
    }
  const auto mean = static_cast<float>(count > 0 ? sum / static_cast<double>(count) : 0.0);
  if (mean > 0.0F)
    for (float& d : density) d /= mean;
}

}  // namespace

CouinaudSegments couinaud_segments_from_atlas(const Mask& organ, const std::string& name,
                                              const Mask* vessels) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(kInf), hi = Eigen::Vector3d::Constant(-kInf);
  for (int64_t v = 0; v < organ.frame.voxel_count(); ++v)
    if (organ.inside[static_cast<size_t>(v)] != 0) {
      const Eigen::Vector3d p = detail::voxel_centre_mm(organ.frame, v);
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  if (!(lo.x() <= hi.x()))
    throw invalid_input(name, "Couinaud's segments: the organ has no voxels");
  const Atlas& a = atlas();
  const int g = a.g;
  const size_t cells = static_cast<size_t>(g) * g * g;
  // Each voxel's place in the box, in bins (continuous; a bin's centre at k + 0.5).
  const Eigen::Vector3d extent = (hi - lo).cwiseMax(Eigen::Vector3d::Constant(1e-9));
  const auto in_box = [&](const Eigen::Vector3d& p) -> Eigen::Vector3d {
    return (p - lo).cwiseQuotient(extent) * g;
  };
  if (vessels != nullptr && vessels->inside.size() != organ.inside.size())
    throw invalid_input(name, "Couinaud's segments: the vessels are not on the organ's grid");
  // The padded grid the voters are bent on (kPadBins round the box, so the outline has room).
  const int n = g + 2 * kPadBins;
  const size_t padded = static_cast<size_t>(n) * n * n;
  const auto at = [n](int x, int y, int z) {
    return static_cast<size_t>(x + n * (y + static_cast<int64_t>(n) * z));
  };
  // The organ's bins as the atlas's bits (every atlas liver's fit is measured on them) and,
  // with vessels, how many of each bin's organ voxels are vessel.
  std::vector<uint64_t> organ_bits(static_cast<size_t>(g) * g, 0);
  std::vector<float> organ_voxels, vessel_voxels;
  if (vessels != nullptr) {
    organ_voxels.assign(padded, 0.0F);
    vessel_voxels.assign(padded, 0.0F);
  }
  int64_t organ_vessel = 0;
  for (int64_t v = 0; v < organ.frame.voxel_count(); ++v)
    if (organ.inside[static_cast<size_t>(v)] != 0) {
      const Eigen::Vector3d u = in_box(detail::voxel_centre_mm(organ.frame, v));
      std::array<int, 3> b{};
      for (int d = 0; d < 3; ++d)
        b[static_cast<size_t>(d)] = std::clamp(static_cast<int>(u[d]), 0, g - 1);
      organ_bits[static_cast<size_t>(b[0] * g + b[1])] |= 1ULL << b[2];
      if (vessels == nullptr) continue;
      const size_t i = at(b[0] + kPadBins, b[1] + kPadBins, b[2] + kPadBins);
      organ_voxels[i] += 1.0F;
      if (vessels->inside[static_cast<size_t>(v)] != 0) {
        vessel_voxels[i] += 1.0F;
        ++organ_vessel;
      }
    }
  if (vessels != nullptr && organ_vessel == 0)
    throw invalid_input(name, "Couinaud's segments: the vessels have no voxels inside the organ");
  const int64_t organ_bins = count_bits(organ_bits.data(), g);
  // The candidates: every atlas liver, or with vessels those whose vessels are known.
  std::vector<int> pool;
  for (int l = 0; l < static_cast<int>(a.numbers.size()); ++l)
    if (vessels == nullptr || a.vessel_slot[static_cast<size_t>(l)] >= 0) pool.push_back(l);
  const int livers = static_cast<int>(pool.size());
  std::vector<Fit> fits(static_cast<size_t>(livers));
#pragma omp parallel for schedule(dynamic)
  for (int c = 0; c < livers; ++c) {
    const int l = pool[static_cast<size_t>(c)];
    fits[static_cast<size_t>(c)] =
        best_shift(organ_bits, organ_bins, a.bits.data() + static_cast<size_t>(l) * g * g,
                   a.bins[static_cast<size_t>(l)], g);
    fits[static_cast<size_t>(c)].liver = l;
  }
  // The most alike vote (ties by the atlas's order, so the result does not depend on threads).
  std::stable_sort(fits.begin(), fits.end(),
                   [](const Fit& p, const Fit& q) { return p.overlap > q.overlap; });
  fits.resize(static_cast<size_t>(std::min(kVoters, livers)));
  // Each voter, moved by its shift, is then bent onto the organ's outline (demons on the two
  // shapes' signed distances) and, with vessels, its vessels onto the organ's inside it; it
  // votes with its labels where the bending carries them.
  std::vector<uint8_t> organ_padded(padded, 0);
  for (int x = 0; x < g; ++x)
    for (int y = 0; y < g; ++y)
      for (int z = 0; z < g; ++z)
        if ((organ_bits[static_cast<size_t>(x * g + y)] >> z & 1ULL) != 0)
          organ_padded[at(x + kPadBins, y + kPadBins, z + kPadBins)] = 1;
  const std::vector<float> organ_phi = detail::signed_distance_voxels(organ_padded, n);
  std::vector<float>& organ_density = vessel_voxels;  // the share, in place
  if (vessels != nullptr) {
    for (size_t i = 0; i < padded; ++i)
      if (organ_voxels[i] > 0.0F) organ_density[i] /= organ_voxels[i];
    normalise_density(organ_density, organ_padded, n);
  }
  std::array<std::vector<float>, 8> votes;  // per segment, n^3, x fastest (sample_trilinear's)
  for (auto& v : votes) v.assign(padded, 0.0F);
  std::vector<std::vector<uint8_t>> warped(fits.size());
#pragma omp parallel for schedule(dynamic)
  for (int f = 0; f < static_cast<int>(fits.size()); ++f) {
    const Fit& fit = fits[static_cast<size_t>(f)];
    const uint8_t* labels = a.labels.data() + static_cast<size_t>(fit.liver) * cells;
    const int slot = a.vessel_slot[static_cast<size_t>(fit.liver)];
    const uint8_t* shares =
        vessels != nullptr ? a.vessels.data() + static_cast<size_t>(slot) * cells : nullptr;
    std::vector<uint8_t> moved(padded, 0), inside(padded, 0);
    std::vector<float> density(shares != nullptr ? padded : 0, 0.0F);
    for (int x = 0; x < g; ++x)
      for (int y = 0; y < g; ++y)
        for (int z = 0; z < g; ++z) {
          const int tx = x + fit.shift[0], ty = y + fit.shift[1], tz = z + fit.shift[2];
          if (tx < 0 || ty < 0 || tz < 0 || tx >= g || ty >= g || tz >= g) continue;
          const uint8_t s = labels[static_cast<size_t>((x * g + y) * g + z)];
          const size_t i = at(tx + kPadBins, ty + kPadBins, tz + kPadBins);
          moved[i] = s;
          inside[i] = s != 0 ? 1 : 0;
          if (shares != nullptr)
            density[i] = shares[static_cast<size_t>((x * g + y) * g + z)] / 255.0F;
        }
    const std::vector<float> phi = detail::signed_distance_voxels(inside, n);
    if (shares != nullptr) normalise_density(density, inside, n);
    warped[static_cast<size_t>(f)] = detail::warp_labels(
        moved,
        shares != nullptr
            ? detail::register_outlines_and_densities(organ_phi, phi, organ_density, density, n)
            : detail::register_outlines(organ_phi, phi, n),
        n);
  }
  for (const auto& w : warped)
    for (size_t i = 0; i < padded; ++i)
      if (w[i] != 0) votes[w[i] - 1u][i] += 1.0F;
  const std::vector<float> kernel = detail::gaussian_kernel(kSmoothBins);
#pragma omp parallel for
  for (int s = 0; s < 8; ++s) {
    std::vector<float> scratch;
    detail::smooth_grid(votes[static_cast<size_t>(s)], {n, n, n}, kernel, scratch);
  }

  // Every voxel: the segment with the most votes where it lies (trilinear between bin centres).
  CouinaudSegments out;
  out.segment.assign(organ.inside.size(), 0);
  const int64_t voxels = organ.frame.voxel_count();
  const std::array<int64_t, 3> size{n, n, n};
#pragma omp parallel for schedule(static)
  for (int64_t v = 0; v < voxels; ++v) {
    if (organ.inside[static_cast<size_t>(v)] == 0) continue;
    const Eigen::Vector3d u =
        in_box(detail::voxel_centre_mm(organ.frame, v)).array() - 0.5 + kPadBins;
    uint8_t best = 1;
    float most = -1.0F;
    for (int s = 0; s < 8; ++s) {
      const float w =
          detail::sample_trilinear(votes[static_cast<size_t>(s)].data(), size, u.x(), u.y(), u.z());
      if (w > most) {
        most = w;
        best = static_cast<uint8_t>(s + 1);
      }
    }
    out.segment[static_cast<size_t>(v)] = best;
  }
  const double voxel_ml = organ.frame.voxel_volume_mm3() / 1000.0;
  for (int64_t v = 0; v < voxels; ++v)
    if (out.segment[static_cast<size_t>(v)] != 0)
      out.volume_ml[out.segment[static_cast<size_t>(v)]] += voxel_ml;

  CouinaudLandmarks& lm = out.landmarks;
  lm.placed_by = CouinaudPlacement::kAtlas;
  lm.atlas_vessels = vessels != nullptr;
  for (const Fit& f : fits) {
    lm.atlas_livers.push_back(a.numbers[static_cast<size_t>(f.liver)]);
    lm.atlas_overlap += f.overlap / static_cast<double>(fits.size());
  }
  return out;
}

}  // namespace lamina::geometry
