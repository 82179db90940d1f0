#include "lamina/model/build_model.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>

#include "build_embedded.h"
#include "explain_failure.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/geometry/extract_isosurface.h"
#include "lamina/geometry/mask_filters.h"
#include "lamina/geometry/mesh_measures.h"
#include "lamina/geometry/plug_tunnels.h"
#include "lamina/geometry/remesh.h"
#include "lamina/geometry/spatial_sort.h"
#include "lamina/model/compute_rings.h"
#include "lamina/model/fill_tetrahedra.h"
#include "link_layers.h"

namespace lamina::model {
namespace {

using Clock = std::chrono::steady_clock;

// OpenVDB adaptivity for the raw isosurfaces the remesher starts from, used only when the
// working grid is at least 3x finer than the target edge. Measured on the phantom (1.5 mm grid,
// 9.4 mm edge): 0 -> 106k raw faces, skin stage 1.2 s, skin volume -0.67%; 0.3 -> 50k faces,
// 0.68 s, -0.82%; 0.5 -> 13k faces, 0.28 s, -1.43%. On the 3 mm kidney (4.8 mm edge) 0.3 saves
// nothing and costs 1.1% of volume, hence the condition.
constexpr double kIsosurfaceAdaptivity = 0.3;

// Tunnels through the organ narrower than a ball of this many skin edges are plugged on the
// working grid (geometry::plug_tunnels): a handle a few triangles round cannot be remeshed at the
// skin's edge length without the skin crossing itself.
constexpr double kPlugRadiusEdges = 1.0;

// The native voxels of `fine` (the prepared mask) whose working-grid voxel a plug filled: `coarse`
// is the working grid made by downsample_mask(fine, factors) and then padded by `pad` voxels.
int64_t add_plugs(Mask& fine, const GridFrame& coarse, const std::vector<uint8_t>& plugged,
                  const std::array<int, 3>& factors, int pad) {
  int64_t n = 0;
  const GridFrame& f = fine.frame;
  for (int64_t k = 0; k < f.size[2]; ++k)
    for (int64_t j = 0; j < f.size[1]; ++j)
      for (int64_t i = 0; i < f.size[0]; ++i) {
        const int64_t c[3] = {i / factors[0] + pad, j / factors[1] + pad, k / factors[2] + pad};
        if (c[0] >= coarse.size[0] - pad || c[1] >= coarse.size[1] - pad ||
            c[2] >= coarse.size[2] - pad)
          continue;  // a trailing partial block, dropped by the downsampling
        uint8_t& v = fine.inside[static_cast<size_t>(f.index(i, j, k))];
        if (!v && plugged[static_cast<size_t>(coarse.index(c[0], c[1], c[2]))]) v = 1, ++n;
      }
  return n;
}

// Target edge length for n vertices covering `area`: a closed genus-0 mesh has about 2n
// triangles of area sqrt(3)/4 * L^2 each. CGAL's isotropic remeshing keeps edges between 4/5
// and 4/3 of its target and settles at a mean about 8% below it (measured on the phantom and
// the shared livers), so we ask for 8% more.
double edge_for_vertex_count(double area_mm2, double n) {
  return 1.08 * std::sqrt(2.0 * area_mm2 / (std::sqrt(3.0) * n));
}

// Vertex area: a third of the area of each incident triangle.
std::vector<double> vertex_areas(const SurfaceMesh& m) {
  std::vector<double> a(static_cast<size_t>(m.V.rows()), 0.0);
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const Eigen::RowVector3d p = m.V.row(m.F(f, 0)), q = m.V.row(m.F(f, 1)), r = m.V.row(m.F(f, 2));
    const double third = (q - p).cross(r - p).norm() / 6.0;
    for (int c = 0; c < 3; ++c) a[m.F(f, c)] += third;
  }
  return a;
}

class StageTimer {
 public:
  explicit StageTimer(BuildReport& r) : report_(r), last_(Clock::now()) {}
  void done(const char* stage) {
    const auto now = Clock::now();
    report_.stage_seconds.emplace_back(stage, std::chrono::duration<double>(now - last_).count());
    last_ = now;
  }

 private:
  BuildReport& report_;
  Clock::time_point last_;
};

// Orders springs by (i, j), so that a pass over them walks the nodes in order.
void sort_springs(Springs& sp) {
  std::vector<size_t> order(sp.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return std::make_pair(sp.i[a], sp.j[a]) < std::make_pair(sp.i[b], sp.j[b]);
  });
  auto permute = [&](auto& v) {
    auto copy = v;
    for (size_t k = 0; k < order.size(); ++k) v[k] = copy[order[k]];
  };
  permute(sp.i);
  permute(sp.j);
  permute(sp.rest_length_mm);
  permute(sp.stiffness_n_per_m);
  permute(sp.kind);
}

}  // namespace

void check_build_options(const BuildOptions& o) {
  if (o.layers < 1 || o.layers > 16)
    throw invalid_input("--layers", "must be between 1 and 16, got " + std::to_string(o.layers));
  if (o.skin_vertices < 50 || o.skin_vertices > 5'000'000)
    throw invalid_input("--skin-vertices",
                        "must be between 50 and 5000000, got " + std::to_string(o.skin_vertices));
  if (!(o.layer_depth_mm >= 0.0) || !std::isfinite(o.layer_depth_mm))
    throw invalid_input("--layer-depth", "must be a positive depth in mm (or 0 for automatic)");
  if (o.locality < 1 || o.locality > 64)
    throw invalid_input("--locality",
                        "must be between 1 and 64, got " + std::to_string(o.locality));
  if (o.inter_layer_links < 1 || o.inter_layer_links > 16)
    throw invalid_input("--links", "must be between 1 and 16");
  if (!(o.density_kg_per_mm3 > 0.0) || !std::isfinite(o.density_kg_per_mm3))
    throw invalid_input("--density", "must be positive");
  if (!(o.stiffness_n_per_m > 0.0) || !std::isfinite(o.stiffness_n_per_m))
    throw invalid_input("--stiffness", "must be positive");
  if (o.structure != Structure::kTetrahedra && o.structure != Structure::kLinks)
    throw invalid_input("--structure", "must be tets or links");
  if (!(o.tet_radius_edge_ratio >= 1.2 && o.tet_radius_edge_ratio <= 10.0))
    throw invalid_input("tet_radius_edge_ratio", "must be between 1.2 and 10");
  if (o.display_triangles != 0 && (o.display_triangles < 100 || o.display_triangles > 10'000'000))
    throw invalid_input(
        "--display-triangles",
        "must be 0 (none) or between 100 and 10000000, got " + std::to_string(o.display_triangles));
  if (o.structure_triangles < 100 || o.structure_triangles > 10'000'000)
    throw invalid_input("--structure-triangles", "must be between 100 and 10000000, got " +
                                                     std::to_string(o.structure_triangles));
  for (int32_t l : o.labels)
    if (l <= 0)
      throw invalid_input("--label", "labels are positive integers, got " + std::to_string(l));
  if (!(o.tet_min_dihedral_deg >= 0.0 && o.tet_min_dihedral_deg <= 18.0))
    throw invalid_input("tet_min_dihedral_deg", "must be between 0 and 18 degrees");
}

BuildResult build_model(const LabelVolume& volume, const BuildOptions& opt,
                        const ProgressFn& progress) {
  check_build_options(opt);
  detail::check_embedding(volume, opt);
  const auto t0 = Clock::now();
  BuildResult result;
  BuildReport& rep = result.report;
  rep.input = volume.source;
  rep.layers_requested = opt.layers;
  StageTimer timer(rep);
  const std::string& name = volume.source;

  // 1. Mask: label, largest component, cavities, crop.
  report_progress(progress, "preparing mask", 0.0);
  // Structures carved out of the organ's label (a voxel is liver or vessel or tumour) count as
  // organ where the organ encloses them.
  geometry::PreparedMask prepared;
  {
    const std::vector<uint8_t> structures = detail::structure_voxels(volume, opt);
    std::vector<uint8_t> whole;  // a tumour is the organ's tissue, all of it
    for (const EmbedStructure& s : opt.embed)
      whole.push_back(structure_role(s) == SurfaceRole::kTumour ? 1 : 0);
    prepared =
        geometry::prepare_mask(volume, {.label = opt.label,
                                        .labels = opt.labels,
                                        .structures = structures.empty() ? nullptr : &structures,
                                        .structure_count = static_cast<int32_t>(opt.embed.size()),
                                        .whole_structures = std::move(whole)});
  }
  detail::check_structures_in_organ(volume, opt, prepared.report);
  rep.mask = prepared.report;
  // An organ named by its label(s) in a map that carves other structures out of it, not
  // embedded: the model would have a dent or a tunnel wherever they run (and if the skin cannot
  // be made because of them, the refusal names them: explain_mesh_failure).
  if (opt.label != 0 || !opt.labels.empty()) {
    const detail::LabelsInside inside = detail::labels_inside_organ(volume, opt, 0.25);
    if (!inside.text.empty())
      rep.warnings.push_back(inside.text +
                             ": structures carved out of it leave tunnels and craters in the "
                             "organ; " +
                             inside.advice());
  }
  for (const EmbedStructure& s : opt.embed) {
    rep.structure_names.push_back(detail::structure_name(s));
    rep.structure_roles.push_back(structure_role(s));
  }
  rep.mask_volume_ml = prepared.report.kept_volume_ml;
  timer.done("mask");

  // 2. Working grid: about four voxels per target edge is enough for the remesher to find the
  // surface to well under an edge; finer input is box-filtered down (saves time and memory on
  // clinical 0.6 mm scans), coarser input is used as is.
  const double area0 = geometry::mask_boundary_area_mm2(prepared.mask);
  double edge = edge_for_vertex_count(area0, opt.skin_vertices);
  const std::array<int, 3> factors =
      geometry::working_grid_factors(prepared.mask.frame.spacing_mm, edge);
  Mask work = geometry::downsample_mask(prepared.mask, factors);
  // The display skin (the last stage) is made at the mask's own resolution.
  const bool display_skin = opt.display_triangles > 0 && opt.structure == Structure::kTetrahedra;
  if (!display_skin) prepared.mask = {};
  work = geometry::pad_mask(work, 2);
  // Downsampling can break a thin bridge or close a pocket: clean once more on the coarse grid.
  const auto cc = geometry::keep_largest_component(work);
  if (cc.components > 1)
    rep.warnings.push_back(
        fmt::format("downsampling split off {} small piece(s) ({} voxels), dropped",
                    cc.components - 1, cc.dropped_voxels));
  geometry::fill_cavities(work);
  rep.working_spacing_mm = work.frame.spacing_mm;

  // Tunnels through the organ that no label fills and that are too narrow for the skin's
  // triangles (a vessel's straight stretch the enclosure rules left, a hole in the segmentation):
  // plugged, by topology, so that grooves and fissures keep their shape (geometry::plug_tunnels).
  // A wider tunnel stays a hole in the model. If the skin still crosses itself (the remesher
  // cannot pass a handle, or a gap, a few of its triangles wide), the mask is made again on the
  // way that skin needs, each step said in the report: (1) with tunnels through corners too (an
  // isosurface may join voxels that touch by a corner alone); (2) with its gaps narrower than a
  // skin edge closed and tunnels up to two edges plugged; (3) gaps up to two edges, tunnels up to
  // four. docs/segmentations.md, "Tunnels no label fills".
  std::vector<uint8_t> plugged(display_skin ? work.inside.size() : 0, 0);
  const auto add_to_plugged = [&](const std::vector<uint8_t>& added) {
    for (size_t v = 0; v < added.size() && v < plugged.size(); ++v) plugged[v] |= added[v];
  };
  DistanceField sdf;
  SurfaceMesh skin;
  double adaptivity = 0.0;
  bool skin_clean = false;  // checked here: it does not cross itself
  for (int attempt = 0;; ++attempt) {
    const double plug_edges = attempt < 2 ? 1.0 : (attempt == 2 ? 2.0 : 4.0);
    if (attempt >= 2) {
      // Gaps narrower than the skin can hold: the mask's closing by half a skin edge (then one).
      const double r = (attempt == 2 ? 0.5 : 1.0) * edge;
      const Mask closed = geometry::close_mask(work, r);
      int64_t n = 0;
      for (size_t v = 0; v < work.inside.size(); ++v)
        if (closed.inside[v] && !work.inside[v]) {
          work.inside[v] = 1, ++n;
          if (!plugged.empty()) plugged[v] = 1;
        }
      rep.gaps.voxels += n;
      rep.gaps.volume_ml += static_cast<double>(n) * work.frame.voxel_volume_mm3() / 1000.0;
      rep.gaps.radius_mm = r;
    }
    std::vector<uint8_t> added;
    const geometry::TunnelPlugs t = geometry::plug_tunnels(
        work, kPlugRadiusEdges * plug_edges * edge, display_skin ? &added : nullptr,
        /*corners=*/attempt >= 1);
    add_to_plugged(added);
    if (attempt == 0) {
      rep.tunnels = t;
    } else {
      rep.tunnels.tunnels_after = t.tunnels_after;
      rep.tunnels.plugs += t.plugs;
      rep.tunnels.radius_mm = std::max(rep.tunnels.radius_mm, t.radius_mm);
      rep.tunnels.voxels += t.voxels;
      rep.tunnels.corner_voxels += t.corner_voxels;
      rep.tunnels.volume_ml += t.volume_ml;
    }
    if (attempt == 0) timer.done("resample");
    report_progress(progress, "signed distance", 0.15);

    // 3. Signed distance field, mm.
    sdf = geometry::signed_distance(work);
    rep.max_depth_mm = -static_cast<double>(*std::min_element(sdf.phi.begin(), sdf.phi.end()));
    if (attempt == 0) timer.done("distance");

    // 4. Skin: the zero isosurface, remeshed to the requested vertex count. The first pass uses
    // the estimated area; the second corrects the edge length from the vertex count achieved.
    report_progress(progress, "skin", 0.3);
    const double coarsest =
        std::max({sdf.frame.spacing_mm[0], sdf.frame.spacing_mm[1], sdf.frame.spacing_mm[2]});
    adaptivity = 3.0 * coarsest <= edge ? kIsosurfaceAdaptivity : 0.0;
    SurfaceMesh raw = geometry::extract_isosurface(sdf, 0.0, adaptivity);
    int pieces = 0;
    raw = geometry::largest_piece(raw, &pieces);
    if (raw.F.rows() == 0) throw invalid_input(name, "no surface could be extracted from the mask");
    // Tunnels through the organ that stay: the model has a hole there.
    rep.skin_genus = detail::surface_genus(raw);
    edge = edge_for_vertex_count(geometry::measure_mesh(raw).area_mm2, opt.skin_vertices);
    skin = geometry::remesh(raw, {.target_edge_mm = edge});
    const double ratio = static_cast<double>(skin.V.rows()) / opt.skin_vertices;
    if (std::abs(ratio - 1.0) > 0.05) {
      edge *= std::sqrt(ratio);
      skin = geometry::remesh(raw, {.target_edge_mm = edge});
    }
    rep.target_edge_mm = edge;
    // The skin is checked with the other layers below; here only whether to make it again.
    if (attempt < 3) skin_clean = !geometry::self_intersects(skin);
    if (attempt < 3 && !skin_clean) {
      rep.skin_attempts = attempt + 2;
      // Tunnels through corners matter only where the skin has a handle.
      if (attempt == 0 && rep.skin_genus == 0) ++attempt;
      continue;
    }
    if (pieces > 1)
      rep.warnings.push_back(fmt::format("skin: kept the largest of {} surface pieces", pieces));
    break;
  }
  work = {};
  if (rep.tunnels.voxels > 0 || rep.gaps.voxels > 0) {
    if (display_skin) add_plugs(prepared.mask, sdf.frame, plugged, factors, 2);
    // The organ the skin should enclose.
    rep.mask_volume_ml += rep.tunnels.volume_ml + rep.gaps.volume_ml;
  }
  if (rep.gaps.voxels > 0)
    rep.warnings.push_back(fmt::format(
        "the skin crossed itself in gaps of the organ narrower than its triangles: closed the "
        "gaps narrower than {:.1f} mm ({:.2f} mL)",
        2.0 * rep.gaps.radius_mm, rep.gaps.volume_ml));
  if (rep.tunnels.plugs > 0)
    rep.warnings.push_back(fmt::format(
        "plugged {} tunnel(s) through the organ narrower than {:.1f} mm ({:.2f} mL); {} wider "
        "one(s) kept",
        rep.tunnels.tunnels_before - rep.tunnels.tunnels_after, 2.0 * rep.tunnels.radius_mm,
        rep.tunnels.volume_ml, rep.tunnels.tunnels_after));
  if (rep.skin_genus > 0)
    rep.warnings.push_back(fmt::format(
        "the organ's surface has {} tunnel(s) through it (genus {}): the model has a hole there",
        rep.skin_genus, rep.skin_genus));
  const double depth_step =
      opt.layer_depth_mm > 0.0 ? opt.layer_depth_mm : rep.max_depth_mm / (opt.layers + 1);
  timer.done("skin");

  std::vector<SurfaceMesh> layers{skin};
  rep.layers.push_back({.index = 0, .depth_mm = 0.0});

  // 5. Inner layers: isosurfaces at increasing depth ("shrink the volume and mesh it again"),
  // remeshed at the skin's edge length so all layers have the same spring scale.
  for (int32_t k = 1; k < opt.layers; ++k) {
    report_progress(progress, fmt::format("layer {}", k), 0.3 + 0.45 * k / opt.layers);
    const double depth = depth_step * k;
    LayerBuildInfo info{.index = k, .depth_mm = depth};
    if (depth >= rep.max_depth_mm) {
      rep.warnings.push_back(fmt::format(
          "layer {} at depth {:.1f} mm vanished: the organ is at most {:.1f} mm deep; the model "
          "has {} layer(s) (use a smaller --layer-depth or fewer --layers)",
          k, depth, rep.max_depth_mm, k));
      break;
    }
    SurfaceMesh iso = geometry::extract_isosurface(sdf, -depth, adaptivity);
    SurfaceMesh mesh = geometry::remesh(iso, {.target_edge_mm = edge});
    // Thin parts of the organ leave small pieces at depth. Keep a piece only if it is big enough
    // to mesh well, closed, free of self-intersections and strictly inside the layer outside it
    // (remeshing moves vertices by a fraction of an edge, which can matter where the organ is
    // barely thicker than twice the depth); drop the others and say so.
    std::vector<SurfaceMesh> kept;
    int32_t crossing = 0;
    info.min_gap_to_outer_mm = std::numeric_limits<double>::infinity();
    for (auto& part : geometry::split_components(mesh)) {
      if (part.V.rows() < opt.min_component_vertices || !geometry::measure_mesh(part).closed ||
          geometry::self_intersects(part)) {
        ++info.dropped_components;
        continue;
      }
      const geometry::Nesting n = geometry::check_nesting(layers.back(), part);
      if (!n.nested()) {
        ++crossing;
        continue;
      }
      info.min_gap_to_outer_mm = std::min(info.min_gap_to_outer_mm, n.min_gap_mm);
      kept.push_back(std::move(part));
    }
    if (info.dropped_components > 0)
      rep.warnings.push_back(
          fmt::format("layer {}: dropped {} piece(s) too small to mesh in thin parts of the organ",
                      k, info.dropped_components));
    if (crossing > 0)
      rep.warnings.push_back(fmt::format(
          "layer {}: dropped {} piece(s) that came too close to layer {} in thin parts of the "
          "organ (a larger --layer-depth spacing or more --skin-vertices keeps them)",
          k, crossing, k - 1));
    info.dropped_components += crossing;
    if (kept.empty()) {
      rep.warnings.push_back(fmt::format(
          "layer {} at depth {:.1f} mm vanished after remeshing; the model has {} layer(s)", k,
          depth, k));
      break;
    }
    if (kept.size() > 1)
      rep.warnings.push_back(
          fmt::format("layer {} splits into {} separate pieces (thin parts of the "
                      "organ); each is linked to the layer outside it",
                      k, kept.size()));
    layers.push_back(geometry::merge_meshes(kept));
    rep.layers.push_back(info);
  }
  timer.done("inner layers");

  // 6. Invariants of every layer (inner pieces were checked one by one above; this also
  // catches two pieces of one layer crossing each other, and checks the skin).
  report_progress(progress, "checking layers", 0.75);
  for (size_t k = 0; k < layers.size(); ++k) {
    const geometry::MeshQuality q = geometry::measure_mesh(layers[k]);
    const bool crossed = k == 0 && skin_clean ? false : geometry::self_intersects(layers[k]);
    std::vector<std::string> failed;
    if (!q.closed) failed.emplace_back("not closed");
    if (!q.manifold) failed.emplace_back("not manifold");
    if (!q.outward) failed.emplace_back("inside out");
    if (q.degenerate_faces > 0)
      failed.push_back(fmt::format("{} degenerate faces", q.degenerate_faces));
    if (crossed) failed.emplace_back("self-intersecting");
    if (!failed.empty())
      throw invalid_input(
          name, detail::explain_mesh_failure(volume, opt, rep, static_cast<int32_t>(k),
                                             fmt::format("{}", fmt::join(failed, ", ")), layers[k],
                                             rep.skin_genus));
  }
  timer.done("checks");

  // 7. Assemble nodes (layer by layer), springs, masses, rings. Each layer's vertices are first
  // put in space-filling-curve order and the springs sorted by their nodes: a simulation step
  // reads every node's neighbours, and this keeps them near in memory (docs/benchmarks.md).
  report_progress(progress, "springs", 0.85);
  for (SurfaceMesh& l : layers) geometry::spatial_sort(l, l);
  Model& m = result.model;
  m.source = volume.source;
  m.density_kg_per_mm3 = opt.density_kg_per_mm3;
  Eigen::Index total = 0;
  for (const auto& l : layers) total += l.V.rows();
  m.X.resize(total, 3);
  m.layer_of.resize(static_cast<size_t>(total));
  m.fixed.assign(static_cast<size_t>(total), 0);
  int32_t first = 0;
  for (size_t k = 0; k < layers.size(); ++k) {
    const auto& l = layers[k];
    ModelLayer ml;
    ml.first_node = first;
    ml.node_count = static_cast<int32_t>(l.V.rows());
    ml.F = l.F.array() + first;
    m.X.middleRows(first, l.V.rows()) = l.V;
    std::fill_n(m.layer_of.begin() + first, l.V.rows(), static_cast<int32_t>(k));
    m.layers.push_back(std::move(ml));
    first += static_cast<int32_t>(l.V.rows());
  }
  std::vector<double> enclosed(layers.size());
  for (size_t k = 0; k < layers.size(); ++k) enclosed[k] = geometry::enclosed_volume(layers[k]);
  if (opt.structure == Structure::kTetrahedra) {
    // The volume between the layers: tetrahedra whose faces on the layers are the layers'
    // triangles; their edges are the springs, their volumes the masses.
    report_progress(progress, "tetrahedra", 0.8);
    rep.tets = fill_tetrahedra({.max_radius_edge_ratio = opt.tet_radius_edge_ratio,
                                .min_dihedral_deg = opt.tet_min_dihedral_deg,
                                // step 6 checked every layer and their nesting with CGAL
                                .check_intersections = false},
                               m);
    rep.interior_nodes = m.node_count() - static_cast<int32_t>(total);
    std::fill(m.springs.stiffness_n_per_m.begin(), m.springs.stiffness_n_per_m.end(),
              opt.stiffness_n_per_m);
    timer.done("tetrahedra");
  } else {
    auto add_spring = [&](int32_t a, int32_t b, SpringKind kind) {
      const double len = (m.X.row(a) - m.X.row(b)).norm();
      m.springs.i.push_back(a);
      m.springs.j.push_back(b);
      m.springs.rest_length_mm.push_back(len);
      m.springs.stiffness_n_per_m.push_back(opt.stiffness_n_per_m);
      m.springs.kind.push_back(kind);
    };
    for (const auto& l : m.layers)
      for (const auto& [a, b] : geometry::mesh_edges(l.F))
        add_spring(a, b, SpringKind::kIntraLayer);
    for (const auto& [a, b] : link_layers(m, opt.inter_layer_links))
      add_spring(a, b, SpringKind::kInterLayer);
    sort_springs(m.springs);

    // Lumped masses: each shell between layers k and k+1 gives half its mass to each of them, the
    // core inside the deepest layer all to it; within a layer, mass follows vertex area. The total
    // is exactly density x skin volume.
    m.mass_kg.assign(static_cast<size_t>(total), 0.0);
    for (size_t k = 0; k < layers.size(); ++k) {
      const bool deepest = k + 1 == layers.size();
      double share = deepest ? enclosed[k] : 0.5 * (enclosed[k] - enclosed[k + 1]);
      if (k > 0) share += 0.5 * (enclosed[k - 1] - enclosed[k]);
      const std::vector<double> va = vertex_areas(layers[k]);
      double area = 0.0;
      for (double a : va) area += a;
      for (size_t v = 0; v < va.size(); ++v)
        m.mass_kg[m.layers[k].first_node + v] = opt.density_kg_per_mm3 * share * va[v] / area;
    }
    timer.done("springs and masses");
  }

  report_progress(progress, "rings", 0.95);
  m.rings = compute_rings(m, opt.locality);
  timer.done("rings");

  // 8. The display skin and the structures, carried by the tetrahedra.
  if (display_skin || !opt.embed.empty()) {
    report_progress(progress, "display skin and structures", 0.97);
    detail::add_embedded(m, volume, prepared.mask, opt, rep);
    timer.done("embedded surfaces");
  }

  rep.skin_volume_error_pct =
      100.0 * (enclosed[0] / 1000.0 - rep.mask_volume_ml) / rep.mask_volume_ml;
  rep.build_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  report_progress(progress, "done", 1.0);
  return result;
}

}  // namespace lamina::model
