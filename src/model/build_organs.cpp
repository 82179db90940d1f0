// Several organs from one segmentation (build_organs.h): the organs' voxels told apart (masks'
// overlaps resolved by their neighbours), each structure given to the organ it lies in or
// against, and each organ built by build_model() on a volume of its own voxels and its
// structures'.
#include "lamina/model/build_organs.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <set>

#include "build_embedded.h"
#include "lamina/core/error.h"

namespace lamina::model {
namespace {

// The organ of each voxel (k + 1, 0 = none) and how many organs claimed it.
struct Owners {
  std::vector<uint8_t> organ;
  std::vector<uint8_t> claims;
};

Owners claim_voxels(const LabelVolume& volume, const std::vector<OrganSource>& organs) {
  const size_t n = volume.labels.size();
  Owners o{std::vector<uint8_t>(n, 0), std::vector<uint8_t>(n, 0)};
  for (size_t k = 0; k < organs.size(); ++k) {
    const OrganSource& src = organs[k];
    const std::vector<int32_t>& labels = src.mask ? src.mask->labels : volume.labels;
    int64_t count = 0;
    for (size_t i = 0; i < n; ++i) {
      if (src.mask ? labels[i] == 0 : labels[i] != src.label) continue;
      ++count;
      if (o.claims[i]++ == 0) o.organ[i] = static_cast<uint8_t>(k + 1);
    }
    if (count == 0)
      throw invalid_input(src.mask ? src.mask->source : volume.source,
                          src.mask
                              ? "organ '" + src.name + "': its mask has no voxel"
                              : fmt::format("organ '{}': the segmentation has no voxel of label {}",
                                            src.name, src.label));
  }
  return o;
}

// Each voxel two or more masks claim goes to the organ most of its 26 neighbours belong to
// (uncontested ones), the first listed on a tie; the overlaps are counted per pair.
std::vector<OrganOverlap> resolve_overlaps(const GridFrame& f, const std::vector<OrganSource>& org,
                                           Owners& o) {
  const auto& sz = f.size;
  std::vector<OrganOverlap> out;
  std::vector<uint8_t> decided = o.organ;
  const size_t count = org.size();
  for (int64_t z = 0; z < sz[2]; ++z)
    for (int64_t y = 0; y < sz[1]; ++y)
      for (int64_t x = 0; x < sz[0]; ++x) {
        const int64_t i = f.index(x, y, z);
        if (o.claims[static_cast<size_t>(i)] < 2) continue;
        // Which organs claim it: the masks themselves, looked at again.
        std::vector<int> claim;
        for (size_t k = 0; k < count; ++k) {
          const OrganSource& s = org[k];
          const bool in = s.mask ? s.mask->labels[static_cast<size_t>(i)] != 0
                                 : false;  // a label is one voxel's only value: never contested
          if (in) claim.push_back(static_cast<int>(k));
        }
        std::vector<int> votes(count, 0);
        for (int dz = -1; dz <= 1; ++dz)
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              const int64_t a = x + dx, b = y + dy, c = z + dz;
              if (a < 0 || b < 0 || c < 0 || a >= sz[0] || b >= sz[1] || c >= sz[2]) continue;
              const size_t j = static_cast<size_t>(f.index(a, b, c));
              if (o.claims[j] == 1) ++votes[o.organ[j] - 1u];
            }
        int best = claim.front();
        for (const int k : claim)
          if (votes[static_cast<size_t>(k)] > votes[static_cast<size_t>(best)]) best = k;
        decided[static_cast<size_t>(i)] = static_cast<uint8_t>(best + 1);
        // Counted per pair of the first two claimants (three-way overlaps are rarer still).
        const std::string& a = org[static_cast<size_t>(claim[0])].name;
        const std::string& b = org[static_cast<size_t>(claim[1])].name;
        auto it = std::find_if(out.begin(), out.end(),
                               [&](const OrganOverlap& p) { return p.a == a && p.b == b; });
        if (it == out.end()) it = out.insert(out.end(), OrganOverlap{.a = a, .b = b});
        ++it->voxels;
        it->to_a += best == claim[0];
      }
  o.organ = std::move(decided);
  return out;
}

// Voxel faces between different organs, per pair.
std::vector<OrganContact> organ_contacts(const GridFrame& f, const std::vector<OrganSource>& org,
                                         const std::vector<uint8_t>& organ) {
  const size_t count = org.size();
  std::vector<int64_t> faces(count * count, 0);
  const std::array<int64_t, 3> step = {1, f.size[0], f.size[0] * f.size[1]};
  for (int64_t z = 0; z < f.size[2]; ++z)
    for (int64_t y = 0; y < f.size[1]; ++y)
      for (int64_t x = 0; x < f.size[0]; ++x) {
        const int64_t i = f.index(x, y, z);
        const uint8_t a = organ[static_cast<size_t>(i)];
        if (a == 0) continue;
        const std::array<int64_t, 3> at = {x, y, z};
        for (int c = 0; c < 3; ++c) {
          if (at[c] + 1 >= f.size[c]) continue;
          const uint8_t b = organ[static_cast<size_t>(i + step[c])];
          if (b != 0 && b != a) ++faces[std::min(a, b) - 1u + count * (std::max(a, b) - 1u)];
        }
      }
  std::vector<OrganContact> out;
  for (size_t a = 0; a < count; ++a)
    for (size_t b = a + 1; b < count; ++b)
      if (faces[a + count * b] > 0)
        out.push_back({.a = org[a].name, .b = org[b].name, .faces = faces[a + count * b]});
  return out;
}

// The organ each structure goes to: the one most of its voxels (`sv`: detail::structure_voxels)
// are in or face-adjacent to.
std::vector<int> structure_owners(const LabelVolume& volume, const BuildOptions& options,
                                  const std::vector<OrganSource>& org,
                                  const std::vector<uint8_t>& organ,
                                  const std::vector<uint8_t>& sv) {
  const size_t ns = options.embed.size(), count = org.size();
  std::vector<int64_t> touch(ns * count, 0);
  const GridFrame& f = volume.frame;
  const std::array<int64_t, 3> step = {1, f.size[0], f.size[0] * f.size[1]};
  for (int64_t z = 0; z < f.size[2]; ++z)
    for (int64_t y = 0; y < f.size[1]; ++y)
      for (int64_t x = 0; x < f.size[0]; ++x) {
        const int64_t i = f.index(x, y, z);
        const uint8_t s = sv.empty() ? 0 : sv[static_cast<size_t>(i)];
        if (s == 0) continue;
        std::array<bool, 256> seen{};
        const auto see = [&](int64_t j) {
          const uint8_t o = organ[static_cast<size_t>(j)];
          if (o != 0 && !seen[o]) {
            seen[o] = true;
            ++touch[(s - 1u) * count + (o - 1u)];
          }
        };
        see(i);
        const std::array<int64_t, 3> at = {x, y, z};
        for (int c = 0; c < 3; ++c) {
          if (at[c] > 0) see(i - step[c]);
          if (at[c] + 1 < f.size[c]) see(i + step[c]);
        }
      }
  std::vector<int> owner(ns, -1);
  for (size_t s = 0; s < ns; ++s) {
    const auto first = touch.begin() + static_cast<std::ptrdiff_t>(s * count);
    const auto best = std::max_element(first, first + static_cast<std::ptrdiff_t>(count));
    if (*best == 0)
      throw invalid_input(
          options.embed[s].mask ? options.embed[s].mask->source : volume.source,
          fmt::format("structure '{}' lies in or against none of the organs; give it to one "
                      "(it must touch an organ's voxels) or leave it out",
                      detail::structure_name(options.embed[s])));
    owner[s] = static_cast<int>(best - first);
  }
  return owner;
}

// Voxel faces of the organ's surface: its size, for the skins' common density.
int64_t surface_faces(const GridFrame& f, const std::vector<uint8_t>& organ, uint8_t k) {
  int64_t n = 0;
  const std::array<int64_t, 3> step = {1, f.size[0], f.size[0] * f.size[1]};
  for (int64_t z = 0; z < f.size[2]; ++z)
    for (int64_t y = 0; y < f.size[1]; ++y)
      for (int64_t x = 0; x < f.size[0]; ++x) {
        const int64_t i = f.index(x, y, z);
        if (organ[static_cast<size_t>(i)] != k) continue;
        const std::array<int64_t, 3> at = {x, y, z};
        for (int c = 0; c < 3; ++c) {
          n += at[c] == 0 || organ[static_cast<size_t>(i - step[c])] != k;
          n += at[c] + 1 == f.size[c] || organ[static_cast<size_t>(i + step[c])] != k;
        }
      }
  return n;
}

void check_organs(const LabelVolume& volume, const std::vector<OrganSource>& organs) {
  if (organs.empty()) throw invalid_input(volume.source, "no organ to build (--organ)");
  if (organs.size() > 250)
    throw invalid_input(volume.source, fmt::format("{} organs: at most 250", organs.size()));
  std::set<std::string> names;
  for (const OrganSource& o : organs) {
    const std::string& file = o.mask ? o.mask->source : volume.source;
    if (o.name.empty()) throw invalid_input(file, "an organ needs a name (LABEL=NAME)");
    if (o.name.find_first_of("/\\\n") != std::string::npos)
      throw invalid_input(file, "organ '" + o.name +
                                    "': a name cannot hold '/', '\\' or a "
                                    "line break (it names the model's file)");
    if (!names.insert(o.name).second)
      throw invalid_input(file, "organ '" + o.name + "' is given twice");
    if (o.mask && !detail::same_grid(o.mask->frame, volume.frame))
      throw invalid_input(
          file, "organ '" + o.name + "': its grid (" + detail::describe_grid(o.mask->frame) +
                    ") is not the segmentation's (" + detail::describe_grid(volume.frame) +
                    "); resample it onto " + volume.source);
    if (!o.mask && o.label <= 0)
      throw invalid_input(file, "organ '" + o.name + "': its label must be > 0");
  }
}

}  // namespace

OrgansResult build_organs(const LabelVolume& volume, const std::vector<OrganSource>& organs,
                          const BuildOptions& options, const ProgressFn& progress) {
  check_organs(volume, organs);
  check_build_options(options);
  Owners owners = claim_voxels(volume, organs);
  OrgansResult result;
  result.overlaps = resolve_overlaps(volume.frame, organs, owners);
  for (const EmbedStructure& s : options.embed)
    for (const OrganSource& o : organs)
      if (!s.mask && !o.mask && s.label == o.label)
        throw invalid_input(volume.source, fmt::format("label {} is organ '{}' and structure '{}': "
                                                       "a label is one or the other",
                                                       s.label, o.name, detail::structure_name(s)));
  // The structures' voxels, once: their owners are found on them and each organ's volume made.
  const std::vector<uint8_t> sv = detail::structure_voxels(volume, options);
  const std::vector<int> owner = structure_owners(volume, options, organs, owners.organ, sv);
  result.contacts = organ_contacts(volume.frame, organs, owners.organ);
  std::vector<int64_t> faces(organs.size());
  for (size_t k = 0; k < organs.size(); ++k)
    faces[k] = surface_faces(volume.frame, owners.organ, static_cast<uint8_t>(k + 1));
  const int64_t largest = *std::max_element(faces.begin(), faces.end());

  // Each organ on a volume of its own: organ voxels label 1, its structures' label-voxels
  // renumbered 2, 3, ... (their masks kept as they are), everything else background.
  for (size_t k = 0; k < organs.size(); ++k) {
    LabelVolume own{.frame = volume.frame,
                    .labels = std::vector<int32_t>(volume.labels.size(), 0),
                    .source = volume.source + " (organ '" + organs[k].name + "')"};
    BuildOptions o = options;
    o.label = 1;
    o.labels.clear();
    o.embed.clear();
    o.skin_vertices = std::max<int32_t>(
        200, static_cast<int32_t>(std::lround(static_cast<double>(options.skin_vertices) *
                                              static_cast<double>(faces[k]) /
                                              static_cast<double>(largest))));
    std::vector<int32_t> relabel(options.embed.size(), 0);
    OrganModel m;
    m.name = organs[k].name;
    for (size_t s = 0; s < options.embed.size(); ++s) {
      if (owner[s] != static_cast<int>(k)) continue;
      EmbedStructure e = options.embed[s];
      e.name = detail::structure_name(e);
      if (!e.mask) {
        relabel[s] = static_cast<int32_t>(o.embed.size()) + 2;
        e.label = relabel[s];
      }
      m.structures.push_back(e.name);
      o.embed.push_back(std::move(e));
    }
    for (size_t i = 0; i < own.labels.size(); ++i) {
      if (owners.organ[i] == k + 1) {
        own.labels[i] = 1;
        ++m.voxels;
      }
      // A structure's voxel inside another organ stays that organ's.
      if (!sv.empty() && sv[i] != 0 && relabel[sv[i] - 1u] != 0 &&
          (owners.organ[i] == 0 || owners.organ[i] == k + 1))
        own.labels[i] = relabel[sv[i] - 1u];
    }
    const ProgressFn stage = progress ? ProgressFn([&](std::string_view what, double f) {
      progress(fmt::format("{}: {}", organs[k].name, what),
               (static_cast<double>(k) + f) / static_cast<double>(organs.size()));
    })
                                      : ProgressFn{};
    try {
      m.built = build_model(own, o, stage);
    } catch (const Error& e) {
      throw Error(e.kind(), fmt::format("organ '{}': {}", organs[k].name, e.what()));
    }
    result.organs.push_back(std::move(m));
  }
  return result;
}

}  // namespace lamina::model
