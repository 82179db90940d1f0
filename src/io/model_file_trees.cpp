// The vessel trees' part of the model file (format version 7, docs/model_format.md): FieldData
// arrays only (ParaView shows the points and cells as before): per tree its name, kind, label
// and counts; per seed (all trees' in order) its rest position, tetrahedron corners, weights,
// offset, the seed upstream of it, its branch and whether it lies in the organ; per branch its
// parent, whether it is rooted, its length, radius and territory.

#include <cmath>
#include <cstdint>
#include <ostream>
#include <string>
#include <vector>

#include "lamina/core/error.h"
#include "model_file_internal.h"

namespace lamina::io::detail {
namespace {

constexpr double kWeightSumTolerance = 1e-9;  // as the embedded surfaces' (embed_surface)

std::string tree_named(const Model& m, size_t t) {
  return "vessel tree " + std::to_string(t) + " (" + in_quotes(m.trees[t].flow.name) + ")";
}

}  // namespace

void check_trees_savable(const Model& m, const std::string& path) {
  for (size_t t = 0; t < m.trees.size(); ++t) {
    const ModelVesselTree& tree = m.trees[t];
    const geometry::TreeFlow& f = tree.flow;
    if (f.name.empty() || f.name.find('\n') != std::string::npos)
      throw invalid_input(path, "cannot save: vessel tree " + std::to_string(t) + " has the name " +
                                    in_quotes(f.name) +
                                    "; a name must be non-empty and on one line");
    const auto s = static_cast<Eigen::Index>(f.seeds());
    const size_t b = f.branches();
    if (f.seed_branch.size() != f.seeds() || tree.seeds.V.rows() != s ||
        tree.seeds.corners.rows() != s || tree.seeds.weights.rows() != s ||
        (tree.seeds.offsets.rows() != 0 && tree.seeds.offsets.rows() != s) ||
        tree.in_organ.size() != f.seeds() || f.branch_rooted.size() != b ||
        f.branch_length_mm.size() != b || f.branch_radius_mm.size() != b ||
        f.branch_territory_ml.size() != b)
      throw Error(ErrorKind::kInternal, path + ": cannot save: " + tree_named(m, t) +
                                            " has arrays that disagree in size");
  }
}

void write_tree_field_data(std::ostream& out, const char* indent, const Model& m) {
  if (m.trees.empty()) return;
  std::vector<int32_t> kind, label, roots, gaps, seed_count, branch_count, upstream, branch, parent;
  std::vector<double> unrooted, position, weights, offsets, length, radius, territory;
  std::vector<int64_t> corners;
  std::vector<uint8_t> names, in_organ, rooted;
  for (const ModelVesselTree& tree : m.trees) {
    const geometry::TreeFlow& f = tree.flow;
    if (!names.empty()) names.push_back('\n');
    names.insert(names.end(), f.name.begin(), f.name.end());
    kind.push_back(static_cast<int32_t>(f.kind));
    label.push_back(tree.label);
    roots.push_back(f.roots);
    gaps.push_back(f.bridged_gaps);
    unrooted.push_back(f.unrooted_mm);
    seed_count.push_back(static_cast<int32_t>(f.seeds()));
    branch_count.push_back(static_cast<int32_t>(f.branches()));
    const EmbeddedSurface& e = tree.seeds;
    for (Eigen::Index v = 0; v < e.V.rows(); ++v) {
      for (int c = 0; c < 3; ++c) {
        position.push_back(e.V(v, c));
        offsets.push_back(e.offsets.rows() > 0 ? e.offsets(v, c) : 0.0);
      }
      for (int c = 0; c < 4; ++c) {
        corners.push_back(e.corners(v, c));
        weights.push_back(e.weights(v, c));
      }
    }
    upstream.insert(upstream.end(), f.seed_upstream.begin(), f.seed_upstream.end());
    branch.insert(branch.end(), f.seed_branch.begin(), f.seed_branch.end());
    in_organ.insert(in_organ.end(), tree.in_organ.begin(), tree.in_organ.end());
    parent.insert(parent.end(), f.branch_parent.begin(), f.branch_parent.end());
    rooted.insert(rooted.end(), f.branch_rooted.begin(), f.branch_rooted.end());
    length.insert(length.end(), f.branch_length_mm.begin(), f.branch_length_mm.end());
    radius.insert(radius.end(), f.branch_radius_mm.begin(), f.branch_radius_mm.end());
    territory.insert(territory.end(), f.branch_territory_ml.begin(), f.branch_territory_ml.end());
  }
  write_array(out, indent, "tree_names", names, 1, true);
  write_array(out, indent, "tree_kind", kind, 1, true);
  write_array(out, indent, "tree_label", label, 1, true);
  write_array(out, indent, "tree_roots", roots, 1, true);
  write_array(out, indent, "tree_bridged_gaps", gaps, 1, true);
  write_array(out, indent, "tree_unrooted_mm", unrooted, 1, true);
  write_array(out, indent, "tree_seed_count", seed_count, 1, true);
  write_array(out, indent, "tree_branch_count", branch_count, 1, true);
  write_array(out, indent, "seed_position", position, 3, true);
  write_array(out, indent, "seed_corners", corners, 4, true);
  write_array(out, indent, "seed_weights", weights, 4, true);
  write_array(out, indent, "seed_offset", offsets, 3, true);
  write_array(out, indent, "seed_upstream", upstream, 1, true);
  write_array(out, indent, "seed_branch", branch, 1, true);
  write_array(out, indent, "seed_in_organ", in_organ, 1, true);
  write_array(out, indent, "branch_parent", parent, 1, true);
  write_array(out, indent, "branch_rooted", rooted, 1, true);
  write_array(out, indent, "branch_length_mm", length, 1, true);
  write_array(out, indent, "branch_radius_mm", radius, 1, true);
  write_array(out, indent, "branch_territory_ml", territory, 1, true);
}

void read_trees(const std::string& path, const VtuFile& f, Model& m) {
  const auto bad = [&](const std::string& problem) { return invalid_input(path, problem); };
  const auto field = [&](const char* name) { return std::string("FieldData/") + name; };
  const int64_t count = tuple_count(path, f, field("tree_kind"));
  const auto kind = read_values<int32_t>(path, f, field("tree_kind"), count);
  const auto label = read_values<int32_t>(path, f, field("tree_label"), count);
  const auto roots = read_values<int32_t>(path, f, field("tree_roots"), count);
  const auto gaps = read_values<int32_t>(path, f, field("tree_bridged_gaps"), count);
  const auto unrooted = read_values<double>(path, f, field("tree_unrooted_mm"), count);
  const auto seed_count = read_values<int32_t>(path, f, field("tree_seed_count"), count);
  const auto branch_count = read_values<int32_t>(path, f, field("tree_branch_count"), count);
  const auto bytes =
      read_values<uint8_t>(path, f, field("tree_names"), tuple_count(path, f, field("tree_names")));
  const std::vector<std::string> names = split_names(bytes);
  if (static_cast<int64_t>(names.size()) != count)
    throw bad("tree_names holds " + std::to_string(names.size()) + " name(s) for " +
              std::to_string(count) + " vessel tree(s)");
  int64_t seeds = 0, branches = 0;
  for (int64_t t = 0; t < count; ++t) {
    if (seed_count[t] <= 0 || branch_count[t] <= 0)
      throw bad("vessel tree " + std::to_string(t) + " has " + std::to_string(seed_count[t]) +
                " seeds and " + std::to_string(branch_count[t]) + " branches; expected > 0");
    seeds += seed_count[t];
    branches += branch_count[t];
  }
  const auto position = read_values<double>(path, f, field("seed_position"), 3 * seeds, 3);
  const auto corners = read_values<int64_t>(path, f, field("seed_corners"), 4 * seeds, 4);
  const auto weights = read_values<double>(path, f, field("seed_weights"), 4 * seeds, 4);
  const auto offsets = read_values<double>(path, f, field("seed_offset"), 3 * seeds, 3);
  const auto upstream = read_values<int32_t>(path, f, field("seed_upstream"), seeds);
  const auto branch = read_values<int32_t>(path, f, field("seed_branch"), seeds);
  const auto in_organ = read_values<uint8_t>(path, f, field("seed_in_organ"), seeds);
  const auto parent = read_values<int32_t>(path, f, field("branch_parent"), branches);
  const auto rooted = read_values<uint8_t>(path, f, field("branch_rooted"), branches);
  const auto length = read_values<double>(path, f, field("branch_length_mm"), branches);
  const auto radius = read_values<double>(path, f, field("branch_radius_mm"), branches);
  const auto territory = read_values<double>(path, f, field("branch_territory_ml"), branches);

  const int32_t n = m.node_count();
  int64_t s0 = 0, b0 = 0;  // the tree's first seed and branch in the arrays
  m.trees.resize(static_cast<size_t>(count));
  for (size_t t = 0; t < m.trees.size(); ++t) {
    ModelVesselTree& tree = m.trees[t];
    geometry::TreeFlow& fl = tree.flow;
    fl.name = names[t];
    if (fl.name.empty()) throw bad("vessel tree " + std::to_string(t) + " has no name");
    const std::string named = tree_named(m, t);
    if (kind[t] != static_cast<int32_t>(geometry::VesselTreeKind::kPortal) &&
        kind[t] != static_cast<int32_t>(geometry::VesselTreeKind::kHepatic))
      throw bad(named + " has kind " + std::to_string(kind[t]) +
                "; expected 1 (portal vein) or 2 (hepatic veins)");
    fl.kind = static_cast<geometry::VesselTreeKind>(kind[t]);
    tree.label = label[t];
    fl.roots = roots[t];
    fl.bridged_gaps = gaps[t];
    fl.unrooted_mm = unrooted[t];
    if (fl.roots < 1 || fl.bridged_gaps < 0 || !(fl.unrooted_mm >= 0.0) ||
        !std::isfinite(fl.unrooted_mm))
      throw bad(named + " has " + std::to_string(fl.roots) + " roots, " +
                std::to_string(fl.bridged_gaps) + " gaps bridged and " + str(fl.unrooted_mm) +
                " mm unrooted; expected a root at least and counts >= 0");
    const int32_t ns = seed_count[t], nb = branch_count[t];
    for (int32_t b = 0; b < nb; ++b) {
      const int64_t k = b0 + b;
      const std::string what = named + " branch " + std::to_string(b) + ": ";
      if (parent[k] < -1 || parent[k] >= nb)
        throw bad(what + "parent " + std::to_string(parent[k]) + " is no branch of the tree");
      if (rooted[k] > 1) throw bad(what + "branch_rooted must be 0 or 1");
      for (const double v : {length[k], radius[k], territory[k]})
        if (!(v >= 0.0) || !std::isfinite(v))
          throw bad(what + "length, radius and territory must be finite and >= 0");
      fl.branch_parent.push_back(parent[k]);
      fl.branch_rooted.push_back(rooted[k]);
      fl.branch_length_mm.push_back(length[k]);
      fl.branch_radius_mm.push_back(radius[k]);
      fl.branch_territory_ml.push_back(territory[k]);
    }
    EmbeddedSurface& e = tree.seeds;
    e.name = fl.name;
    e.label = tree.label;
    e.role = SurfaceRole::kVessel;
    e.V.resize(ns, 3);
    e.F.resize(0, 3);
    e.corners.resize(ns, 4);
    e.weights.resize(ns, 4);
    e.offsets.setZero(ns, 3);
    bool any_offset = false;
    for (int32_t v = 0; v < ns; ++v) {
      const int64_t k = s0 + v;
      const std::string what = named + " seed " + std::to_string(v) + ": ";
      if (upstream[k] < -1 || upstream[k] >= v)
        throw bad(what + "upstream seed " + std::to_string(upstream[k]) +
                  " does not come before it (each seed follows the one upstream of it)");
      if (branch[k] < 0 || branch[k] >= nb)
        throw bad(what + "branch " + std::to_string(branch[k]) + " is no branch of the tree");
      if (in_organ[k] > 1) throw bad(what + "seed_in_organ must be 0 or 1");
      fl.seed_upstream.push_back(upstream[k]);
      fl.seed_branch.push_back(branch[k]);
      tree.in_organ.push_back(in_organ[k]);
      double sum = 0.0;
      for (int c = 0; c < 4; ++c) {
        const int64_t node = corners[4 * k + c];
        if (node < 0 || node >= n)
          throw bad(what + "corner " + std::to_string(node) + " is not a node (the model has " +
                    std::to_string(n) + ")");
        e.corners(v, c) = static_cast<int>(node);
        e.weights(v, c) = weights[4 * k + c];
        if (!std::isfinite(e.weights(v, c))) throw bad(what + "a weight is not finite");
        sum += e.weights(v, c);
      }
      if (!(std::abs(sum - 1.0) <= kWeightSumTolerance))
        throw bad(what + "weights sum to " + str(sum) + ", expected 1 (within 1e-9)");
      for (int c = 0; c < 3; ++c) {
        e.V(v, c) = position[3 * k + c];
        e.offsets(v, c) = offsets[3 * k + c];
        any_offset |= e.offsets(v, c) != 0.0;
      }
      if (!e.V.row(v).allFinite() || !e.offsets.row(v).allFinite())
        throw bad(what + "position or offset is not finite");
    }
    if (!any_offset) e.offsets.resize(0, 3);
    s0 += ns;
    b0 += nb;
  }
}

uint32_t trees_fingerprint(uint32_t c, const Model& m) {
  const auto vec = [&](const auto& v) { c = crc(c, v.data(), v.size() * sizeof(v[0])); };
  for (const ModelVesselTree& tree : m.trees) {
    const geometry::TreeFlow& f = tree.flow;
    c = crc(c, f.name.data(), f.name.size());
    c = crc(c, "\n", 1);
    c = crc(c, &f.kind, sizeof f.kind);
    c = crc(c, &tree.label, sizeof tree.label);
    vec(f.seed_upstream);
    vec(f.seed_branch);
    vec(tree.in_organ);
    vec(f.branch_parent);
    vec(f.branch_rooted);
    vec(f.branch_length_mm);
    vec(f.branch_radius_mm);
    vec(f.branch_territory_ml);
    c = surface_fingerprint(c, tree.seeds, /*roles=*/true);
  }
  return c;
}

}  // namespace lamina::io::detail
