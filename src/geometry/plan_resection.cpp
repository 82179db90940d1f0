// plan_resection (plan_resection.h): the organ's voxels by their side of the surface, the
// tumours' margins and the structures' crossings.
#include "lamina/geometry/plan_resection.h"

#include <omp.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>

#include "lamina/core/error.h"
#include "lamina/geometry/make_phantom.h"
#include "lamina/geometry/mask_filters.h"
#include "lamina/geometry/prepare_mask.h"
#include "lamina/geometry/skeletonize.h"
#include "lamina/geometry/vessel_graph.h"

namespace lamina::geometry {
namespace {

// The grid's axes as physical steps: voxel (i, j, k) is at origin + i a0 + j a1 + k a2.
struct Axes {
  Eigen::Vector3d origin, step[3], dir[3];
  double spacing[3];
  explicit Axes(const GridFrame& f) {
    origin = Eigen::Vector3d(f.origin_mm[0], f.origin_mm[1], f.origin_mm[2]);
    for (int a = 0; a < 3; ++a) {
      dir[a] = Eigen::Vector3d(f.direction[a], f.direction[3 + a], f.direction[6 + a]);
      spacing[a] = f.spacing_mm[a];
      step[a] = spacing[a] * dir[a];
    }
  }
  Eigen::Vector3d at(int64_t i, int64_t j, int64_t k) const {
    return origin + static_cast<double>(i) * step[0] + static_cast<double>(j) * step[1] +
           static_cast<double>(k) * step[2];
  }
  // Half a voxel box's extent along unit n: its centre is farther than this from a plane with
  // normal n exactly when the plane misses the box.
  double half_extent(const Eigen::Vector3d& n) const {
    return 0.5 * (spacing[0] * std::abs(n.dot(dir[0])) + spacing[1] * std::abs(n.dot(dir[1])) +
                  spacing[2] * std::abs(n.dot(dir[2])));
  }
};

enum : uint8_t { kOutside = 0, kFront = 1, kBack = 2 };

// The share of a voxel box whose centre is `s` mm in front of a plane with unit normal n that
// lies in front of it. Across the plane the box's points are s - h + sum_i u_i w_i, with u_i
// uniform on [0, 1] and w_i = |n . edge_i| (h = sum w / 2): the share behind is the
// distribution of a sum of uniforms at h - s, a piecewise cubic (inclusion-exclusion over the
// box's corners, divided by d! and the d widths that are not zero). Exact: sub-samples would
// round the share to their grid, the same way in every voxel of a plane parallel to the faces.
double front_share(double s, const Eigen::Vector3d& n, const Axes& axes) {
  double w[3];
  int d = 0;
  double widest = 0.0;
  for (int a = 0; a < 3; ++a)
    widest = std::max(widest, axes.spacing[a] * std::abs(n.dot(axes.dir[a])));
  for (int a = 0; a < 3; ++a) {
    const double wa = axes.spacing[a] * std::abs(n.dot(axes.dir[a]));
    if (wa > 1e-6 * widest) w[d++] = wa;  // an edge along the plane changes nothing
  }
  double h = 0.0;
  for (int a = 0; a < d; ++a) h += 0.5 * w[a];
  const double x = h - s;  // the box's extent behind the plane, measured from its far side
  if (x <= 0.0) return 1.0;
  if (x >= 2.0 * h) return 0.0;
  double sum = 0.0, product = 1.0, factorial = 1.0;
  for (int a = 0; a < d; ++a) product *= w[a], factorial *= a + 1;
  for (int corner = 0; corner < (1 << d); ++corner) {
    double t = x;
    int bits = 0;
    for (int a = 0; a < d; ++a)
      if (corner >> a & 1) t -= w[a], ++bits;
    if (t > 0.0) sum += (bits % 2 ? -1.0 : 1.0) * std::pow(t, d);
  }
  const double behind = std::clamp(sum / (factorial * product), 0.0, 1.0);
  return 1.0 - behind;
}

// A structure voxel inside the organ that the surface passes through.
struct CrossingVoxel {
  int32_t structure = 0;
  int64_t index = 0;  // in the organ mask's grid
  Eigen::Vector3d nearest = Eigen::Vector3d::Zero();
  double half_extent = 0.0;
};

}  // namespace

double flr_threshold_percent(LiverCondition condition) {
  switch (condition) {
    case LiverCondition::kNormal:
      return 20.0;
    case LiverCondition::kChemotherapy:
      return 30.0;
    case LiverCondition::kCirrhosis:
      return 40.0;
  }
  return 20.0;
}

const char* to_string(LiverCondition condition) {
  switch (condition) {
    case LiverCondition::kNormal:
      return "normal";
    case LiverCondition::kChemotherapy:
      return "chemotherapy";
    case LiverCondition::kCirrhosis:
      return "cirrhosis";
  }
  return "normal";
}

void fill_volumes(ResectionReport& r, double front_mm3, double back_mm3, double least_mm3,
                  std::optional<double> keep_signed_mm, const ResectionOptions& opt,
                  const std::string& source) {
  const double whole_mm3 = front_mm3 + back_mm3;
  if (std::min(front_mm3, back_mm3) < least_mm3)
    throw invalid_input(source, "the resection surface misses the organ: all of its " +
                                    std::to_string(static_cast<int64_t>(whole_mm3 / 1000.0 + 0.5)) +
                                    " mL lie on one side");
  r.input = source;
  r.liver = opt.liver;
  r.margin_mm = opt.margin_mm;
  if (keep_signed_mm) {
    if (!std::isfinite(*keep_signed_mm) || *keep_signed_mm == 0.0)
      throw invalid_input("--keep", "the point to keep lies on the resection surface");
    r.remnant_in_front = *keep_signed_mm > 0.0;
  } else {
    r.remnant_in_front = front_mm3 >= back_mm3;
  }
  r.whole_ml = whole_mm3 / 1000.0;
  r.remnant_ml = (r.remnant_in_front ? front_mm3 : back_mm3) / 1000.0;
  r.resected_ml = (r.remnant_in_front ? back_mm3 : front_mm3) / 1000.0;
  r.flr_percent = 100.0 * r.remnant_ml / r.whole_ml;
  r.flr_threshold_percent = flr_threshold_percent(opt.liver);
  r.flr_sufficient = r.flr_percent >= r.flr_threshold_percent;
}

void file_remnant_pieces(ResectionReport& r, const std::vector<RemnantPiece>& pieces) {
  for (const RemnantPiece& p : pieces) {
    if (p.volume_ml >= kMinPieceMl)
      r.remnant_pieces.push_back(p);
    else
      r.remnant_fragments_ml += p.volume_ml;
  }
  std::sort(r.remnant_pieces.begin(), r.remnant_pieces.end(),
            [](const RemnantPiece& a, const RemnantPiece& b) { return a.volume_ml > b.volume_ml; });
}

LabelVolume planning_phantom() {
  PhantomOptions o;
  o.carved_out = true;
  o.anatomy = true;
  return make_phantom(o);
}

ResectionOptions planning_phantom_options() {
  ResectionOptions o;
  o.organ_labels = {kPhantomLiver};
  o.structures = {{kPhantomVessel, "portal_vein", SurfaceRole::kVessel},
                  {kPhantomTumour, "tumour", SurfaceRole::kTumour},
                  {kPhantomHepaticVeins, "hepatic_veins", SurfaceRole::kVessel},
                  {kPhantomVenaCava, "vena_cava", SurfaceRole::kVessel}};
  return o;
}

ResectionPlan plan_resection(const LabelVolume& volume, const SideOf& side,
                             const ResectionOptions& opt) {
  const GridFrame& f = volume.frame;
  const std::string& source = volume.source;
  const size_t n_voxels = volume.labels.size();
  const int32_t n_structures = static_cast<int32_t>(opt.structures.size());
  if (n_structures > 254) throw invalid_input(source, "at most 254 structures can be planned");

  // Each structure's voxels (s + 1), its count and its box on the input's grid.
  std::vector<uint8_t> structures(n_voxels, 0);
  std::vector<int64_t> count(opt.structures.size(), 0);
  std::vector<std::array<int64_t, 6>> box(opt.structures.size(),
                                          {INT64_MAX, INT64_MAX, INT64_MAX, -1, -1, -1});
  if (n_structures > 0) {
    for (int64_t k = 0; k < f.size[2]; ++k)
      for (int64_t j = 0; j < f.size[1]; ++j)
        for (int64_t i = 0; i < f.size[0]; ++i) {
          const int64_t v = f.index(i, j, k);
          const int32_t l = volume.labels[static_cast<size_t>(v)];
          if (l == 0) continue;
          for (int32_t s = 0; s < n_structures; ++s) {
            if (opt.structures[s].label != l) continue;
            structures[static_cast<size_t>(v)] = static_cast<uint8_t>(s + 1);
            ++count[s];
            auto& b = box[s];
            b = {std::min(b[0], i), std::min(b[1], j), std::min(b[2], k),
                 std::max(b[3], i), std::max(b[4], j), std::max(b[5], k)};
            break;
          }
        }
    for (int32_t s = 0; s < n_structures; ++s)
      if (count[s] == 0)
        throw invalid_input(source, "label " + std::to_string(opt.structures[s].label) + " (" +
                                        opt.structures[s].name + ") is not in the segmentation");
  }

  // The organ, as `lamina build` makes it: its labels and the structure voxels it encloses.
  MaskOptions mo;
  if (opt.organ_labels.size() == 1) mo.label = opt.organ_labels[0];
  if (opt.organ_labels.size() > 1) mo.labels = opt.organ_labels;
  mo.structures = n_structures > 0 ? &structures : nullptr;
  mo.structure_count = n_structures;
  for (const ResectionStructure& s : opt.structures)
    mo.whole_structures.push_back(s.role == SurfaceRole::kTumour ? 1 : 0);
  ResectionPlan plan;
  plan.organ = prepare_mask(volume, mo).mask;
  const Mask& organ = plan.organ;
  const GridFrame& g = organ.frame;
  const Axes in_axes(f), axes(g);
  // The mask's voxel (i, j, k) is the input's (i + off): same spacing and directions.
  std::array<int64_t, 3> off{};
  {
    const Eigen::Vector3d d = axes.origin - in_axes.origin;
    for (int a = 0; a < 3; ++a)
      off[a] = static_cast<int64_t>(std::llround(d.dot(in_axes.dir[a]) / in_axes.spacing[a]));
  }
  const auto input_index = [&](int64_t i, int64_t j, int64_t k) -> int64_t {
    i += off[0], j += off[1], k += off[2];
    if (i < 0 || j < 0 || k < 0 || i >= f.size[0] || j >= f.size[1] || k >= f.size[2]) return -1;
    return f.index(i, j, k);
  };
  // Every voxel of the mask's grid, as visit(v, i, j, k): the maps written back to the input's
  // grid (input_index(i, j, k)) go through it.
  const auto each_mask_voxel = [&](const auto& visit) {
    for (int64_t k = 0; k < g.size[2]; ++k)
      for (int64_t j = 0; j < g.size[1]; ++j)
        for (int64_t i = 0; i < g.size[0]; ++i) visit(g.index(i, j, k), i, j, k);
  };

  // 1. Every organ voxel's side; the ones the surface passes through split exactly. Blocks of
  // voxels far from the surface are decided by their centre (one query for 64 voxels: the
  // triangles' queries are the cost). Each row of blocks sums its own volumes, added in order
  // afterwards: the same sums on any number of threads.
  const double voxel_mm3 = g.voxel_volume_mm3();
  constexpr int64_t kBlock = 4;
  double block_radius = 0.0;
  for (int a = 0; a < 3; ++a)
    block_radius += std::pow(static_cast<double>(kBlock) * axes.spacing[a], 2);
  block_radius = 0.5 * std::sqrt(block_radius);
  std::vector<uint8_t> sides(organ.inside.size(), kOutside);
  std::vector<std::vector<CrossingVoxel>> crossing_parts(
      static_cast<size_t>(omp_get_max_threads()));
  const int64_t blocks[3] = {(g.size[0] + kBlock - 1) / kBlock, (g.size[1] + kBlock - 1) / kBlock,
                             (g.size[2] + kBlock - 1) / kBlock};
  std::vector<double> row_front(static_cast<size_t>(blocks[1] * blocks[2]), 0.0),
      row_back(row_front.size(), 0.0);
#pragma omp parallel for collapse(2) schedule(dynamic, 4)
  for (int64_t bk = 0; bk < blocks[2]; ++bk)
    for (int64_t bj = 0; bj < blocks[1]; ++bj) {
      auto& crossings = crossing_parts[static_cast<size_t>(omp_get_thread_num())];
      double& front_mm3 = row_front[static_cast<size_t>(bk * blocks[1] + bj)];
      double& back_mm3 = row_back[static_cast<size_t>(bk * blocks[1] + bj)];
      for (int64_t bi = 0; bi < blocks[0]; ++bi) {
        const int64_t lo[3] = {bi * kBlock, bj * kBlock, bk * kBlock};
        const int64_t hi[3] = {std::min(lo[0] + kBlock, g.size[0]),
                               std::min(lo[1] + kBlock, g.size[1]),
                               std::min(lo[2] + kBlock, g.size[2])};
        bool any = false;
        for (int64_t k = lo[2]; k < hi[2] && !any; ++k)
          for (int64_t j = lo[1]; j < hi[1] && !any; ++j)
            for (int64_t i = lo[0]; i < hi[0] && !any; ++i) any = organ.inside[g.index(i, j, k)];
        if (!any) continue;
        const Eigen::Vector3d centre =
            axes.at(lo[0], lo[1], lo[2]) +
            0.5 * static_cast<double>(kBlock - 1) * (axes.step[0] + axes.step[1] + axes.step[2]);
        const double block_side = side.signed_mm(centre);
        const bool whole = std::abs(block_side) > block_radius;
        for (int64_t k = lo[2]; k < hi[2]; ++k)
          for (int64_t j = lo[1]; j < hi[1]; ++j)
            for (int64_t i = lo[0]; i < hi[0]; ++i) {
              const int64_t v = g.index(i, j, k);
              if (!organ.inside[v]) continue;
              if (whole) {
                sides[v] = block_side > 0.0 ? kFront : kBack;
                (block_side > 0.0 ? front_mm3 : back_mm3) += voxel_mm3;
                continue;
              }
              const SideQuery q = side.query(axes.at(i, j, k));
              const double h = axes.half_extent(q.normal);
              sides[v] = q.signed_mm > 0.0 ? kFront : kBack;
              if (std::abs(q.signed_mm) >= h) {
                (q.signed_mm > 0.0 ? front_mm3 : back_mm3) += voxel_mm3;
                continue;
              }
              // The voxel's share in front of the surface's tangent plane at its nearest point
              // (the plane itself for a plane: exact).
              const double share = front_share(q.signed_mm, q.normal, axes);
              front_mm3 += share * voxel_mm3;
              back_mm3 += (1.0 - share) * voxel_mm3;
              const int64_t w = input_index(i, j, k);
              const int32_t s = w < 0 ? 0 : structures[static_cast<size_t>(w)];
              if (s > 0 && opt.structures[s - 1].role != SurfaceRole::kTumour)
                crossings.push_back({s - 1, v, q.nearest, h});
            }
      }
    }
  double front_mm3 = 0.0, back_mm3 = 0.0;
  for (size_t row = 0; row < row_front.size(); ++row) {
    front_mm3 += row_front[row];
    back_mm3 += row_back[row];
  }
  ResectionReport& r = plan.report;
  std::optional<double> keep;
  if (opt.keep_point) keep = side.signed_mm(*opt.keep_point);
  fill_volumes(r, front_mm3, back_mm3, voxel_mm3, keep, opt, source);
  const uint8_t remnant = r.remnant_in_front ? kFront : kBack;

  // 2. The parts on the input's grid, and the remnant's pieces.
  plan.parts.frame = f;
  plan.parts.source = source;
  plan.parts.labels.assign(n_voxels, 0);
  Mask rest;
  rest.frame = g;
  rest.inside.assign(organ.inside.size(), 0);
  each_mask_voxel([&](int64_t v, int64_t i, int64_t j, int64_t k) {
    if (sides[v] == kOutside) return;
    const bool kept = sides[v] == remnant;
    rest.inside[v] = kept;
    (kept ? r.remnant_voxels : r.resected_voxels) += 1;
    const int64_t w = input_index(i, j, k);
    if (w >= 0) plan.parts.labels[static_cast<size_t>(w)] = kept ? 1 : 2;
  });
  {
    std::vector<int32_t> piece_of;
    const int32_t pieces = label_components(rest, /*fully_connected=*/false, piece_of);
    std::vector<RemnantPiece> all(static_cast<size_t>(pieces));
    for (int64_t k = 0; k < g.size[2]; ++k)
      for (int64_t j = 0; j < g.size[1]; ++j)
        for (int64_t i = 0; i < g.size[0]; ++i) {
          const int32_t p = piece_of[g.index(i, j, k)];
          if (p == 0) continue;
          all[p - 1].volume_ml += voxel_mm3 / 1000.0;
          all[p - 1].centre_mm += axes.at(i, j, k) * voxel_mm3 / 1000.0;
        }
    for (RemnantPiece& p : all) {
      p.centre_mm /= p.volume_ml;
      if (p.volume_ml >= kMinPieceMl)
        r.remnant_pieces.push_back(p);
      else
        r.remnant_fragments_ml += p.volume_ml;
    }
    std::sort(
        r.remnant_pieces.begin(), r.remnant_pieces.end(),
        [](const RemnantPiece& a, const RemnantPiece& b) { return a.volume_ml > b.volume_ml; });
  }

  // 2b. The functional remnant: the trees of the portal vein and hepatic veins, their
  // territories, what the resection cuts off.
  std::vector<VesselGraph> merged;  // labels holding both trees: for the segments only
  std::string merged_names;
  std::optional<Mask> vessel_union;  // every vessel tree's voxels, for the atlas's segments
  // Structure s's voxels on the organ's grid.
  const auto structure_mask = [&](int32_t s) {
    Mask m;
    m.frame = g;
    m.inside.assign(organ.inside.size(), 0);
    each_mask_voxel([&](int64_t v, int64_t i, int64_t j, int64_t k) {
      const int64_t w = input_index(i, j, k);
      m.inside[v] = w >= 0 && structures[static_cast<size_t>(w)] == s + 1;
    });
    return m;
  };
  // The vena cava, when given: where the hepatic veins' trees are rooted.
  std::optional<Mask> cava;
  for (int32_t s = 0; s < n_structures && !cava; ++s)
    if (is_vena_cava_name(opt.structures[s].name)) cava = structure_mask(s);
  for (int32_t s = 0; s < n_structures; ++s) {
    const ResectionStructure& st = opt.structures[s];
    const VesselTreeKind kind = vessel_tree_kind(st.name);
    if (kind == VesselTreeKind::kNone || st.role == SurfaceRole::kTumour) continue;
    const Mask vessel = structure_mask(s);
    if (opt.segments) {  // the atlas lines its livers' vessels up with these
      if (!vessel_union) vessel_union = vessel;
      for (size_t v = 0; v < vessel.inside.size(); ++v) vessel_union->inside[v] |= vessel.inside[v];
    }
    if (kind == VesselTreeKind::kMerged) {
      // Only the vessels' placement reads a merged label's centrelines (auto takes the atlas).
      if (opt.segments && opt.segments_from == SegmentPlacement::kVessels)
        merged.push_back(vessel_graph(skeletonize(vessel)));
      merged_names += (merged_names.empty() ? "" : ", ") + st.name;
      continue;
    }
    plan.trees.push_back(
        vascular_tree(organ, vessel, source, st.name, kind, st.label,
                      kind == VesselTreeKind::kHepatic && cava ? &*cava : nullptr));
  }
  if (plan.trees.empty()) {
    r.functional_missing =
        merged_names.empty()
            ? "no portal vein or hepatic veins among the structures (name them: --embed "
              "LABEL=portal_vein,LABEL=hepatic_veins)"
            : "the portal vein and hepatic veins come as one label (" + merged_names +
                  "): they are not told apart yet; give them as two labels";
  } else {
    std::vector<uint8_t> function;
    r.functional = functional_remnant(plan.trees, organ, rest.inside, r.remnant_ml, function);
    r.functional_flr_percent = 100.0 * r.functional->functional_ml / r.whole_ml;
    r.functional_sufficient = r.functional_flr_percent >= r.flr_threshold_percent;
    plan.function.frame = f;
    plan.function.source = source;
    plan.function.labels.assign(n_voxels, 0);
    plan.territories.assign(plan.trees.size(), plan.function);
    each_mask_voxel([&](int64_t v, int64_t i, int64_t j, int64_t k) {
      const int64_t w = input_index(i, j, k);
      if (w < 0 || organ.inside[v] == 0) return;
      plan.function.labels[static_cast<size_t>(w)] = function[v];
      for (size_t t = 0; t < plan.trees.size(); ++t) {
        const TreeTerritories& tt = plan.trees[t].territories;
        const int32_t seed = tt.seed_of[v];
        plan.territories[t].labels[static_cast<size_t>(w)] =
            seed < 0 ? 0 : tt.seed_branch[static_cast<size_t>(seed)] + 1;
      }
    });
  }

  // 2c. Couinaud's segments: from the trees' centrelines together, or by the atlas.
  if (opt.segments) {
    // The atlas needs only the organ; the vessels' placement (and auto's choice) the vessels.
    if (plan.trees.empty() && merged_names.empty() && opt.segments_from != SegmentPlacement::kAtlas)
      throw invalid_input(source,
                          "Couinaud's segments need the portal vein and hepatic veins among the "
                          "structures (--embed LABEL=portal_vein,LABEL=hepatic_veins, or one "
                          "label named liver_vessels), or --segments-from atlas for the organ "
                          "alone");
    bool portal = false, hepatic = false;
    for (const VascularTree& vt : plan.trees) {
      portal = portal || vt.kind == VesselTreeKind::kPortal;
      hepatic = hepatic || vt.kind == VesselTreeKind::kHepatic;
    }
    const bool from_vessels =
        opt.segments_from == SegmentPlacement::kVessels ||
        (opt.segments_from == SegmentPlacement::kAuto && portal && hepatic && merged_names.empty());
    const CouinaudSegments cs = [&] {
      const Mask* atlas_vessels = vessel_union ? &*vessel_union : nullptr;
      if (!from_vessels) return couinaud_segments_from_atlas(organ, source, atlas_vessels);
      // The trees' centrelines together, as one graph.
      VesselGraph all;
      all.frame = g;
      std::vector<const VesselGraph*> graphs;
      for (const VascularTree& vt : plan.trees) graphs.push_back(&vt.territories.tree.graph);
      for (const VesselGraph& mg : merged) graphs.push_back(&mg);
      for (const VesselGraph* gp : graphs) {
        const VesselGraph& tg = *gp;
        const auto base = static_cast<int32_t>(all.nodes.size());
        all.nodes.insert(all.nodes.end(), tg.nodes.begin(), tg.nodes.end());
        for (VesselGraph::Branch b : tg.branches) {
          b.a += base;
          b.b += base;
          all.branches.push_back(std::move(b));
        }
      }
      if (opt.segments_from == SegmentPlacement::kVessels)
        return couinaud_segments(organ, all, source);
      try {
        return couinaud_segments(organ, all, source);
      } catch (const Error& e) {
        r.segment_fallback = e.what();
        return couinaud_segments_from_atlas(organ, source, atlas_vessels);
      }
    }();
    r.segment_landmarks = cs.landmarks;
    r.segment_ml = cs.volume_ml;
    std::array<int64_t, 9> in_segment{}, resected{};
    plan.segments.frame = f;
    plan.segments.source = source;
    plan.segments.labels.assign(n_voxels, 0);
    each_mask_voxel([&](int64_t v, int64_t i, int64_t j, int64_t k) {
      const uint8_t s = cs.segment[static_cast<size_t>(v)];
      if (s == 0) return;
      ++in_segment[s];
      resected[s] += rest.inside[static_cast<size_t>(v)] == 0;
      const int64_t w = input_index(i, j, k);
      if (w >= 0) plan.segments.labels[static_cast<size_t>(w)] = s;
    });
    for (size_t s = 1; s <= 8; ++s)
      r.segment_resected_percent[s] = in_segment[s] > 0 ? 100.0 * static_cast<double>(resected[s]) /
                                                              static_cast<double>(in_segment[s])
                                                        : 0.0;
  }

  // 3. Each tumour's pieces against the surface.
  for (int32_t s = 0; s < n_structures; ++s) {
    if (opt.structures[s].role != SurfaceRole::kTumour) continue;
    const auto& b = box[s];
    Mask t;
    t.frame = f;
    t.frame.size = {b[3] - b[0] + 1, b[4] - b[1] + 1, b[5] - b[2] + 1};
    t.frame.origin_mm = f.to_physical(static_cast<double>(b[0]), static_cast<double>(b[1]),
                                      static_cast<double>(b[2]));
    t.inside.assign(static_cast<size_t>(t.frame.voxel_count()), 0);
    for (int64_t k = b[2]; k <= b[5]; ++k)
      for (int64_t j = b[1]; j <= b[4]; ++j)
        for (int64_t i = b[0]; i <= b[3]; ++i)
          t.inside[t.frame.index(i - b[0], j - b[1], k - b[2])] =
              structures[static_cast<size_t>(f.index(i, j, k))] == s + 1;
    std::vector<int32_t> piece_of;
    const int32_t pieces = label_components(t, /*fully_connected=*/true, piece_of);
    struct Acc {
      int64_t voxels = 0, front = 0, back = 0;
      bool divided = false;
      double margin = INFINITY;
      Eigen::Vector3d centre = Eigen::Vector3d::Zero(), nearest = Eigen::Vector3d::Zero();
    };
    std::vector<Acc> acc(static_cast<size_t>(pieces));
    // Each piece's voxels on the organ's grid, for its portal territory.
    const VascularTree* portal_tree = nullptr;
    for (const VascularTree& vt : plan.trees)
      if (vt.kind == VesselTreeKind::kPortal && portal_tree == nullptr) portal_tree = &vt;
    std::vector<std::vector<int64_t>> in_organ(portal_tree ? acc.size() : 0);
    for (int64_t k = b[2]; k <= b[5]; ++k)
      for (int64_t j = b[1]; j <= b[4]; ++j)
        for (int64_t i = b[0]; i <= b[3]; ++i) {
          const int32_t p = piece_of[t.frame.index(i - b[0], j - b[1], k - b[2])];
          if (p == 0) continue;
          Acc& a = acc[p - 1];
          const int64_t gi = i - off[0], gj = j - off[1], gk = k - off[2];
          if (portal_tree && gi >= 0 && gj >= 0 && gk >= 0 && gi < g.size[0] && gj < g.size[1] &&
              gk < g.size[2])
            in_organ[static_cast<size_t>(p - 1)].push_back(g.index(gi, gj, gk));
          const Eigen::Vector3d x = in_axes.at(i, j, k);
          const SideQuery q = side.query(x);
          const double gap = std::abs(q.signed_mm) - in_axes.half_extent(q.normal);
          ++a.voxels;
          a.centre += x;
          (q.signed_mm > 0.0 ? a.front : a.back) += 1;
          if (gap <= 0.0) a.divided = true;
          if (gap < a.margin) {
            a.margin = gap;
            a.nearest = q.nearest;
          }
        }
    std::vector<size_t> order(acc.size());
    std::iota(order.begin(), order.end(), size_t{0});
    std::sort(order.begin(), order.end(),
              [&](size_t x, size_t y) { return acc[x].voxels > acc[y].voxels; });
    int32_t piece = 0;
    for (const size_t o : order) {
      const Acc& a = acc[o];
      TumourMargin tm;
      tm.name = opt.structures[s].name;
      tm.label = opt.structures[s].label;
      tm.piece = ++piece;
      tm.volume_ml = static_cast<double>(a.voxels) * f.voxel_volume_mm3() / 1000.0;
      tm.centre_mm = a.centre / static_cast<double>(a.voxels);
      tm.nearest_mm = a.nearest;
      const bool divided = a.divided || (a.front > 0 && a.back > 0);
      tm.margin_mm = divided ? 0.0 : a.margin;
      const bool in_front = a.front > 0;
      tm.side = divided ? "divided" : (in_front == r.remnant_in_front ? "remnant" : "resected");
      tm.clear = tm.side == "resected" && tm.margin_mm >= opt.margin_mm;
      if (portal_tree)
        tm.territory = tumour_territory(*portal_tree, in_organ[o], voxel_mm3 / 1000.0);
      r.tumours.push_back(tm);
    }
  }

  // 4. Each structure's crossings: connected sets of its voxels the surface passes through.
  std::vector<CrossingVoxel> crossing_voxels;
  for (auto& part : crossing_parts)
    crossing_voxels.insert(crossing_voxels.end(), part.begin(), part.end());
  // In the grid's order, whichever thread found them: the same sums every run.
  std::sort(crossing_voxels.begin(), crossing_voxels.end(),
            [](const CrossingVoxel& a, const CrossingVoxel& b) { return a.index < b.index; });
  for (int32_t s = 0; s < n_structures; ++s) {
    if (opt.structures[s].role == SurfaceRole::kTumour) continue;
    Mask cut;
    cut.frame = g;
    cut.inside.assign(organ.inside.size(), 0);
    bool any = false;
    for (const CrossingVoxel& c : crossing_voxels)
      if (c.structure == s) cut.inside[c.index] = 1, any = true;
    if (!any) continue;
    std::vector<int32_t> piece_of;
    const int32_t pieces = label_components(cut, /*fully_connected=*/true, piece_of);
    std::vector<StructureCrossing> found(static_cast<size_t>(pieces));
    std::vector<int64_t> voxels(static_cast<size_t>(pieces), 0);
    for (const CrossingVoxel& c : crossing_voxels) {
      if (c.structure != s) continue;
      const int32_t p = piece_of[c.index];
      // A layer of voxel centres within h of the surface on either side holds, per unit of the
      // surface's area, 2h / voxel volume of them.
      found[p - 1].area_mm2 += voxel_mm3 / (2.0 * c.half_extent);
      found[p - 1].position_mm += c.nearest;
      ++voxels[p - 1];
    }
    for (int32_t p = 0; p < pieces; ++p) {
      StructureCrossing& c = found[p];
      c.name = opt.structures[s].name;
      c.role = opt.structures[s].role;
      c.label = opt.structures[s].label;
      c.position_mm /= static_cast<double>(voxels[p]);
      c.diameter_mm = 2.0 * std::sqrt(c.area_mm2 / M_PI);
      r.crossings.push_back(c);
    }
  }
  std::sort(r.crossings.begin(), r.crossings.end(),
            [](const StructureCrossing& a, const StructureCrossing& b) {
              return a.diameter_mm > b.diameter_mm;
            });
  return plan;
}

}  // namespace lamina::geometry
