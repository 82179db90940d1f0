#include "explain_failure.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <map>
#include <vector>

#include "build_embedded.h"
#include "lamina/geometry/enclosed_structures.h"
#include "lamina/geometry/remesh.h"

namespace lamina::model::detail {
namespace {

bool is_organ_label(int32_t l, const BuildOptions& o) {
  if (l == 0) return false;
  if (!o.labels.empty()) return std::find(o.labels.begin(), o.labels.end(), l) != o.labels.end();
  return o.label == 0 || l == o.label;
}

bool is_embedded_label(int32_t l, const BuildOptions& o) {
  return std::any_of(o.embed.begin(), o.embed.end(),
                     [&](const EmbedStructure& s) { return !s.mask && s.label == l; });
}

std::string organ_labels(const BuildOptions& o) {
  if (!o.labels.empty()) return fmt::format("labels {}", fmt::join(o.labels, ","));
  return o.label == 0 ? "every non-zero label" : fmt::format("label {}", o.label);
}

// "2, 3 and 5"
std::string and_list(const std::vector<std::string>& items) {
  std::string s;
  for (size_t k = 0; k < items.size(); ++k)
    s += (k == 0 ? "" : k + 1 == items.size() ? " and " : ", ") + items[k];
  return s;
}

// The distinct non-zero labels of the volume, in order (at most 256 looked at).
std::vector<int32_t> present_labels(const LabelVolume& v) {
  std::vector<int32_t> seen;
  for (const int32_t l : v.labels)
    if (l != 0 && std::find(seen.begin(), seen.end(), l) == seen.end()) {
      seen.push_back(l);
      if (seen.size() >= 256) break;
    }
  std::sort(seen.begin(), seen.end());
  return seen;
}

}  // namespace

int32_t surface_genus(const SurfaceMesh& mesh) {
  if (mesh.F.rows() == 0) return 0;
  int components = 0;
  geometry::face_components(mesh.F, mesh.V.rows(), components);
  std::vector<uint8_t> used(static_cast<size_t>(mesh.V.rows()), 0);
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    for (int c = 0; c < 3; ++c) used[static_cast<size_t>(mesh.F(f, c))] = 1;
  int64_t vertices = 0;
  for (const uint8_t u : used) vertices += u;
  const int64_t euler = vertices - static_cast<int64_t>(geometry::mesh_edges(mesh.F).size()) +
                        static_cast<int64_t>(mesh.F.rows());
  return static_cast<int32_t>(std::max<int64_t>(0, (2 * components - euler) / 2));
}

std::string LabelsInside::advice() const {
  std::vector<std::string> embed;
  for (const int32_t l : labels) embed.push_back(fmt::format("{}=NAME", l));
  return fmt::format("embed them (--embed {}) and they count as organ where it encloses them",
                     fmt::join(embed, ","));
}

LabelsInside labels_inside_organ(const LabelVolume& volume, const BuildOptions& o,
                                 double min_share) {
  // The other labels, each a "structure" of its own, against the organ's own voxels.
  std::vector<int32_t> others;
  for (const int32_t l : present_labels(volume))
    if (!is_organ_label(l, o) && !is_embedded_label(l, o) && others.size() < 255)
      others.push_back(l);
  LabelsInside out;
  if (others.empty()) return out;
  const GridFrame& f = volume.frame;
  std::vector<uint8_t> organ(volume.labels.size(), 0), structures(volume.labels.size(), 0);
  std::array<int64_t, 3> lo{f.size[0], f.size[1], f.size[2]}, hi{-1, -1, -1};
  for (int64_t k = 0; k < f.size[2]; ++k)
    for (int64_t j = 0; j < f.size[1]; ++j)
      for (int64_t i = 0; i < f.size[0]; ++i) {
        const size_t v = static_cast<size_t>(f.index(i, j, k));
        const int32_t l = volume.labels[v];
        if (is_organ_label(l, o)) {
          organ[v] = 1;
          lo = {std::min(lo[0], i), std::min(lo[1], j), std::min(lo[2], k)};
          hi = {std::max(hi[0], i), std::max(hi[1], j), std::max(hi[2], k)};
        } else if (l != 0) {
          const auto at = std::find(others.begin(), others.end(), l);
          if (at != others.end()) structures[v] = static_cast<uint8_t>(at - others.begin() + 1);
        }
      }
  if (hi[0] < 0) return out;
  const geometry::EnclosedCounts c = geometry::add_enclosed_structures(
      f, organ, structures, static_cast<int32_t>(others.size()), {}, lo, hi);
  std::vector<std::string> names, counts;
  for (size_t s = 0; s < others.size(); ++s)
    if (c.inside[s] > 0 &&
        static_cast<double>(c.inside[s]) >= min_share * static_cast<double>(c.voxels[s])) {
      names.push_back(std::to_string(others[s]));
      counts.push_back(std::to_string(c.inside[s]));
      out.labels.push_back(others[s]);
    }
  if (names.empty()) return out;
  out.text = fmt::format("{} {} {} inside the organ's {} ({} voxel(s))",
                         names.size() == 1 ? "label" : "labels", and_list(names),
                         names.size() == 1 ? "lies" : "lie", organ_labels(o), and_list(counts));
  return out;
}

std::string explain_mesh_failure(const LabelVolume& volume, const BuildOptions& o,
                                 const BuildReport& rep, int32_t layer, const std::string& failed,
                                 const SurfaceMesh& mesh, int32_t skin_genus) {
  std::string where;
  if (failed.find("self-intersecting") != std::string::npos) {
    const geometry::SelfIntersection x = geometry::find_self_intersection(mesh);
    if (x.pairs > 0)
      where = fmt::format(" near ({:.0f}, {:.0f}, {:.0f}) mm", x.where[0], x.where[1], x.where[2]);
  }
  const std::string head =
      fmt::format("layer {} failed its mesh checks ({}){}: ", layer, failed, where);
  // Structures carved out of the organ's label and not embedded: the tunnels they leave.
  const LabelsInside inside = labels_inside_organ(volume, o);
  if (!inside.text.empty())
    return head + inside.text +
           ": structures carved out of it, which leave tunnels and craters in the organ; " +
           inside.advice();
  // Every label as the organ, where the segmentation has several: vessels that leave the organ
  // (a portal trunk, the vena cava) come with it as thin tubes.
  const std::vector<int32_t> present = present_labels(volume);
  if (o.label == 0 && o.labels.empty() && present.size() > 1) {
    // The organ is most likely the largest label; the advice is a command line that builds.
    std::map<int32_t, int64_t> count;
    for (const int32_t l : volume.labels)
      if (l != 0) ++count[l];
    const int32_t organ =
        std::max_element(count.begin(), count.end(), [](const auto& a, const auto& b) {
          return a.second < b.second;
        })->first;
    std::vector<std::string> names, embed;
    for (const int32_t l : present) {
      names.push_back(std::to_string(l));
      if (l != organ) embed.push_back(fmt::format("{}=NAME", l));
    }
    return head + fmt::format(
                      "the organ is every non-zero label ({}) together, with any vessel that "
                      "leaves it; name the organ's own label and embed the others, e.g. "
                      "--label {} --embed {} (label {} is the largest): they then count as "
                      "organ only where it surrounds them",
                      and_list(names), organ, fmt::join(embed, ","), organ);
  }
  // Tunnels narrower than a skin edge were plugged (geometry::plug_tunnels); these are wider,
  // yet the skin could not pass through them cleanly.
  if (skin_genus > 0)
    return head + fmt::format(
                      "the organ's {} keeps {} tunnel(s) through it wider than {:.1f} mm that no "
                      "label fills (its surface's genus is {}), and its skin's triangles (edges "
                      "of {:.1f} mm) cross there; fill them in the segmentation, or give the "
                      "skin finer triangles (--skin-vertices {})",
                      organ_labels(o), skin_genus, 2.0 * rep.target_edge_mm, skin_genus,
                      rep.target_edge_mm, 4 * o.skin_vertices);
  return head + fmt::format(
                    "parts of the organ are thinner than the skin's triangles (edges of "
                    "{:.1f} mm){}; try a different --skin-vertices (more vertices resolve thinner "
                    "parts){}",
                    rep.target_edge_mm,
                    rep.mask.touches_scan_border ? ", or end at the scan's edge" : "",
                    layer > 0 ? " or fewer --layers" : "");
}

}  // namespace lamina::model::detail
