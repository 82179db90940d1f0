#include "build_embedded.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>
#include <set>

#include "lamina/core/error.h"
#include "lamina/geometry/display_skin.h"
#include "lamina/geometry/functional_remnant.h"
#include "lamina/geometry/mesh_measures.h"
#include "lamina/geometry/structure_names.h"
#include "lamina/model/embed_surface.h"

namespace lamina::model::detail {
namespace {

// Where a structure's voxels come from, for messages: its own mask file or the segmentation.
const LabelVolume& source_of(const EmbedStructure& s, const LabelVolume& organ) {
  return s.mask ? *s.mask : organ;
}

// The voxels of structure `s` on the organ mask's grid (a crop of the segmentation's: the same
// spacing and axes, shifted by whole voxels).
Mask structure_on_organ_grid(const EmbedStructure& s, const LabelVolume& volume,
                             const Mask& organ) {
  const LabelVolume& v = source_of(s, volume);
  const GridFrame &f = organ.frame, &g = v.frame;
  std::array<int64_t, 3> shift{};
  for (int a = 0; a < 3; ++a) {
    double along = 0.0;  // the organ grid's origin along the volume's axis a, in voxels
    for (int r = 0; r < 3; ++r) along += g.direction[3 * r + a] * (f.origin_mm[r] - g.origin_mm[r]);
    shift[a] = std::llround(along / g.spacing_mm[a]);
  }
  Mask m;
  m.frame = f;
  m.inside.assign(static_cast<size_t>(f.voxel_count()), 0);
  for (int64_t k = 0; k < f.size[2]; ++k)
    for (int64_t j = 0; j < f.size[1]; ++j)
      for (int64_t i = 0; i < f.size[0]; ++i) {
        const int64_t a = i + shift[0], b = j + shift[1], c = k + shift[2];
        if (a < 0 || b < 0 || c < 0 || a >= g.size[0] || b >= g.size[1] || c >= g.size[2]) continue;
        const int32_t l = v.labels[static_cast<size_t>(g.index(a, b, c))];
        m.inside[static_cast<size_t>(f.index(i, j, k))] = s.label != 0 ? l == s.label : l != 0;
      }
  return m;
}

// The tree of a structure named a portal vein or hepatic veins (geometry::vessel_tree_kind), its
// seeds embedded in the rest tetrahedra; none (and a warning) when no tree is found.
void add_tree(Model& m, const EmbedStructure& s, const LabelVolume& volume, const Mask& organ,
              const Mask* cava, BuildReport& report) {
  const std::string name = structure_name(s);
  const geometry::VesselTreeKind kind = geometry::vessel_tree_kind(name);
  if (kind != geometry::VesselTreeKind::kPortal && kind != geometry::VesselTreeKind::kHepatic)
    return;
  if (structure_role(s) == SurfaceRole::kTumour) return;
  geometry::VascularTree tree;
  try {
    tree = geometry::vascular_tree(organ, structure_on_organ_grid(s, volume, organ), "", name, kind,
                                   s.label,
                                   kind == geometry::VesselTreeKind::kHepatic ? cava : nullptr);
  } catch (const Error& e) {
    report.warnings.push_back(
        fmt::format("no vessel tree for {}: {}; a plan on this model gives no functional remnant",
                    name, e.what()));
    return;
  }
  const geometry::TreeTerritories& t = tree.territories;
  ModelVesselTree mt;
  mt.flow = geometry::tree_flow(tree, organ.frame.voxel_volume_mm3() / 1000.0);
  mt.flow.name = name;
  mt.label = s.label;
  Eigen::MatrixX3d X(static_cast<Eigen::Index>(t.seeds.size()), 3);
  const GridFrame& f = organ.frame;
  for (size_t q = 0; q < t.seeds.size(); ++q) {
    const int64_t v = t.seeds[q];
    const std::array<double, 3> p = f.to_physical(static_cast<double>(v % f.size[0]),
                                                  static_cast<double>((v / f.size[0]) % f.size[1]),
                                                  static_cast<double>(v / (f.size[0] * f.size[1])));
    X.row(static_cast<Eigen::Index>(q)) << p[0], p[1], p[2];
    mt.in_organ.push_back(organ.inside[static_cast<size_t>(v)]);
  }
  mt.seeds = embed_points(m, X, name, SurfaceRole::kVessel, s.label);
  mt.seeds.outside = 0;  // not kept for seeds (ModelVesselTree::seeds)
  m.trees.push_back(std::move(mt));
}

}  // namespace

std::string describe_grid(const GridFrame& f) {
  return fmt::format("{}x{}x{} voxels of {:g}x{:g}x{:g} mm at ({:g}, {:g}, {:g})", f.size[0],
                     f.size[1], f.size[2], f.spacing_mm[0], f.spacing_mm[1], f.spacing_mm[2],
                     f.origin_mm[0], f.origin_mm[1], f.origin_mm[2]);
}

// Same voxels in space: sizes equal, spacing, origin and directions to a micrometre.
bool same_grid(const GridFrame& a, const GridFrame& b) {
  if (a.size != b.size) return false;
  for (int c = 0; c < 3; ++c)
    if (std::abs(a.spacing_mm[c] - b.spacing_mm[c]) > 1e-3 ||
        std::abs(a.origin_mm[c] - b.origin_mm[c]) > 1e-3)
      return false;
  for (int c = 0; c < 9; ++c)
    if (std::abs(a.direction[c] - b.direction[c]) > 1e-6) return false;
  return true;
}

}  // namespace lamina::model::detail

namespace lamina::model {

SurfaceRole structure_role(const EmbedStructure& s) {
  return s.role ? *s.role : geometry::guess_role(detail::structure_name(s));
}

}  // namespace lamina::model

namespace lamina::model::detail {

std::string structure_name(const EmbedStructure& s) {
  if (!s.name.empty()) return s.name;
  if (s.mask && !s.mask->source.empty())
    return std::filesystem::path(s.mask->source).stem().stem().string();
  return "label " + std::to_string(s.label);
}

void check_embedding(const LabelVolume& volume, const BuildOptions& o) {
  if (o.embed.empty()) return;
  if (o.embed.size() > 255)
    throw invalid_input("--embed", fmt::format("at most 255 structures, got {}", o.embed.size()));
  if (o.structure != Structure::kTetrahedra)
    throw invalid_input("--embed",
                        "embedded structures are carried by tetrahedra; build with "
                        "--structure tets");
  std::set<std::string> names;
  for (const EmbedStructure& s : o.embed) {
    const LabelVolume& v = source_of(s, volume);
    const std::string file = v.source.empty() ? std::string("input") : v.source;
    const std::string what = "structure '" + structure_name(s) + "'";
    if (!names.insert(structure_name(s)).second)
      throw invalid_input(file, "two structures are named '" + structure_name(s) +
                                    "'; give each its own name (LABEL=NAME)");
    if (structure_name(s).find('\n') != std::string::npos)
      throw invalid_input(file, what + ": a name cannot hold a line break");
    if (!is_anatomy(structure_role(s)))
      throw invalid_input(file, what +
                                    ": a structure is a vessel, a tumour or a structure, not a " +
                                    std::string(role_name(structure_role(s))));
    if (s.mask) {
      if (!same_grid(s.mask->frame, volume.frame))
        throw invalid_input(file, what + ": its grid (" + describe_grid(s.mask->frame) +
                                      ") is not the segmentation's (" +
                                      describe_grid(volume.frame) + "); resample the mask onto " +
                                      volume.source);
    } else {
      // A label that is also the organ's (--label 1,2 --embed 2=NAME) is the union layout:
      // all its voxels are organ, and it is embedded as well.
      if (s.label == 0)
        throw invalid_input(file, "--embed label 0 is the background; name a structure's label");
    }
    const bool present =
        s.label == 0
            ? std::any_of(v.labels.begin(), v.labels.end(), [](int32_t l) { return l != 0; })
            : std::find(v.labels.begin(), v.labels.end(), s.label) != v.labels.end();
    if (!present)
      throw invalid_input(file, s.label == 0 ? what + ": the mask is empty (no non-zero voxel)"
                                             : "label " + std::to_string(s.label) + " (" + what +
                                                   ") is absent or empty");
  }
}

std::vector<uint8_t> structure_voxels(const LabelVolume& volume, const BuildOptions& o) {
  if (o.embed.empty()) return {};
  std::vector<uint8_t> out(volume.labels.size(), 0);
  // Labels of the organ's own segmentation, in one pass; separate masks one pass each.
  std::vector<std::pair<int32_t, uint8_t>> by_label;
  for (size_t s = 0; s < o.embed.size(); ++s)
    if (!o.embed[s].mask) by_label.emplace_back(o.embed[s].label, static_cast<uint8_t>(s + 1));
  const int64_t n = static_cast<int64_t>(volume.labels.size());
  if (!by_label.empty()) {
#pragma omp parallel for schedule(static)
    for (int64_t v = 0; v < n; ++v) {
      const int32_t l = volume.labels[static_cast<size_t>(v)];
      if (l == 0) continue;
      for (const auto& [label, index] : by_label)
        if (l == label) {
          out[static_cast<size_t>(v)] = index;
          break;
        }
    }
  }
  for (size_t s = 0; s < o.embed.size(); ++s) {
    const EmbedStructure& e = o.embed[s];
    if (!e.mask) continue;
    const std::vector<int32_t>& labels = e.mask->labels;
    const uint8_t index = static_cast<uint8_t>(s + 1);
#pragma omp parallel for schedule(static)
    for (int64_t v = 0; v < n; ++v) {
      const int32_t l = labels[static_cast<size_t>(v)];
      if (out[static_cast<size_t>(v)] == 0 && (e.label == 0 ? l != 0 : l == e.label))
        out[static_cast<size_t>(v)] = index;
    }
  }
  return out;
}

void check_structures_in_organ(const LabelVolume& volume, const BuildOptions& o,
                               const geometry::MaskReport& mask) {
  const geometry::EnclosedCounts& c = mask.structures;
  for (size_t s = 0; s < o.embed.size() && s < c.voxels.size(); ++s) {
    if (c.inside[s] > 0 || c.beside[s] > 0) continue;
    const EmbedStructure& e = o.embed[s];
    const LabelVolume& v = source_of(e, volume);
    const std::string file = v.source.empty() ? std::string("input") : v.source;
    const std::string what =
        (e.label != 0 ? "label " + std::to_string(e.label) + " (structure '" : "structure '") +
        structure_name(e) + (e.label != 0 ? "')" : "'");
    throw invalid_input(
        file, fmt::format("{}: none of its {} voxels lies inside the organ or within {} voxels "
                          "of it; a structure to embed must be in the organ (is it another "
                          "organ's label?)",
                          what, c.voxels[s], geometry::kBesideVoxels));
  }
}

void add_embedded(Model& m, const LabelVolume& volume, const Mask& organ, const BuildOptions& o,
                  BuildReport& report) {
  if (!m.has_tets()) return;
  const auto add = [&](const SurfaceMesh& surface, const std::string& name, SurfaceRole role,
                       int32_t label) {
    m.embedded.push_back(embed_surface(m, surface.V, surface.F, name, role, label));
    const EmbeddedSurface& e = m.embedded.back();
    report.embedded.push_back({.name = name,
                               .role = role,
                               .label = label,
                               .vertices = e.V.rows(),
                               .faces = e.F.rows(),
                               .outside = e.outside,
                               .volume_ml = geometry::enclosed_volume(surface) / 1000.0});
    // The display skin lies on the mask's boundary, outside the coarse skin's flat faces wherever
    // the organ is convex: its outside vertices are expected (counted, not warned about). A
    // structure's are worth a note: it reaches beyond the organ.
    if (e.outside > 0 && role != SurfaceRole::kDisplaySkin)
      report.warnings.push_back(fmt::format(
          "{}: {} of {} vertices lie outside the organ's tetrahedra; they follow the nearest one",
          name, e.outside, e.V.rows()));
  };
  if (o.display_triangles > 0)
    add(geometry::display_skin(organ, o.display_triangles), kDisplaySkinName,
        SurfaceRole::kDisplaySkin, 0);
  // The vena cava, when embedded: where the hepatic veins' trees are rooted.
  std::optional<Mask> cava;
  for (const EmbedStructure& s : o.embed)
    if (!cava && geometry::is_vena_cava_name(structure_name(s)))
      cava = structure_on_organ_grid(s, volume, organ);
  for (const EmbedStructure& s : o.embed) {
    const LabelVolume& v = source_of(s, volume);
    geometry::MaskOptions select{.label = s.label, .clean = false, .min_voxels = 1};
    const Mask mask = geometry::prepare_mask(v, select).mask;
    add(geometry::structure_surface(mask, o.structure_triangles, structure_name(s)),
        structure_name(s), structure_role(s), s.label);
    add_tree(m, s, volume, organ, cava ? &*cava : nullptr, report);
  }
}

}  // namespace lamina::model::detail
