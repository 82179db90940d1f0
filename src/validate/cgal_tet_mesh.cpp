// Tetrahedral meshing of a mask with CGAL Mesh_3: the only translation unit of the validate
// module that sees CGAL (a Mesh_3 TU needs ~40 s and ~3 GB to compile).
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Image_3.h>
#include <CGAL/Labeled_mesh_domain_3.h>
#include <CGAL/Mesh_complex_3_in_triangulation_3.h>
#include <CGAL/Mesh_criteria_3.h>
#include <CGAL/Mesh_triangulation_3.h>
#include <CGAL/Random.h>
#include <CGAL/make_mesh_3.h>
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <vector>

#include "lamina/core/error.h"
#include "lamina/geometry/mask_filters.h"
#include "lamina/geometry/prepare_mask.h"
#include "lamina/validate/tet_mesh.h"

namespace lamina::validate {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Domain = CGAL::Labeled_mesh_domain_3<K>;
// Sequential on purpose: the parallel mesher's result depends on thread timing.
using Tr = CGAL::Mesh_triangulation_3<Domain, CGAL::Default, CGAL::Sequential_tag>::type;
using C3t3 = CGAL::Mesh_complex_3_in_triangulation_3<Tr>;
using Criteria = CGAL::Mesh_criteria_3<Tr>;

// Voxels of background kept around the mask's bounding box, so that the interpolated surface
// closes inside the image (outside it CGAL reads value_outside, 0, anyway; the margin keeps the
// surface away from the image's own bounding box, which also bounds the domain).
constexpr int64_t kPad = 2;

double signed_volume6(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                      const Eigen::Vector3d& d) {
  return (b - a).dot((c - a).cross(d - a));
}

void check_mask(const Mask& mask, const TetMeshOptions& o) {
  const GridFrame& f = mask.frame;
  for (int a = 0; a < 3; ++a) {
    if (f.size[a] < 1)
      throw invalid_input("mesh_mask_tets: mask", fmt::format("has size {} along axis {}; must be "
                                                              ">= 1",
                                                              f.size[a], a));
    if (!std::isfinite(f.spacing_mm[a]) || f.spacing_mm[a] <= 0.0)
      throw invalid_input(
          "mesh_mask_tets: mask.frame.spacing_mm",
          fmt::format("must be finite and > 0, got {} along axis {}", f.spacing_mm[a], a));
    if (!std::isfinite(f.origin_mm[a]))
      throw invalid_input("mesh_mask_tets: mask.frame.origin_mm", "must be finite");
  }
  for (double d : f.direction)
    if (!std::isfinite(d))
      throw invalid_input("mesh_mask_tets: mask.frame.direction", "must be finite");
  if (static_cast<int64_t>(mask.inside.size()) != f.voxel_count())
    throw invalid_input(
        "mesh_mask_tets: mask.inside",
        fmt::format("has {} values for {} voxels", mask.inside.size(), f.voxel_count()));
  auto check_option = [](double v, const char* name) {
    if (!std::isfinite(v) || v < 0.0)
      throw invalid_input(fmt::format("mesh_mask_tets: options.{}", name),
                          fmt::format("must be >= 0 (0 = automatic), got {}", v));
  };
  check_option(o.cell_size_mm, "cell_size_mm");
  check_option(o.facet_distance_mm, "facet_distance_mm");
  if (!(o.facet_angle_deg > 0.0 && o.facet_angle_deg <= 30.0))
    throw invalid_input("mesh_mask_tets: options.facet_angle_deg",
                        fmt::format("must be in (0, 30], got {}", o.facet_angle_deg));
  if (!(o.sliver_angle_deg >= 0.0 && o.sliver_angle_deg < 30.0))
    throw invalid_input("mesh_mask_tets: options.sliver_angle_deg",
                        fmt::format("must be in [0, 30) (0 = off), got {}", o.sliver_angle_deg));
  if (!(o.cell_radius_edge_ratio >= 2.0 && std::isfinite(o.cell_radius_edge_ratio)))
    throw invalid_input("mesh_mask_tets: options.cell_radius_edge_ratio",
                        fmt::format("must be >= 2, got {}", o.cell_radius_edge_ratio));
}

// Bounding box of the inside voxels; hi[0] < 0 when there is none.
void inside_box(const Mask& mask, std::array<int64_t, 3>& lo, std::array<int64_t, 3>& hi) {
  const GridFrame& frame = mask.frame;
  lo = {frame.size[0], frame.size[1], frame.size[2]};
  hi = {-1, -1, -1};
  for (int64_t k = 0; k < frame.size[2]; ++k)
    for (int64_t j = 0; j < frame.size[1]; ++j)
      for (int64_t i = 0; i < frame.size[0]; ++i)
        if (mask.inside[frame.index(i, j, k)]) {
          const std::array<int64_t, 3> p{i, j, k};
          for (int a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], p[a]);
            hi[a] = std::max(hi[a], p[a]);
          }
        }
}

}  // namespace

TetMesh mesh_mask_tets(const Mask& input, const TetMeshOptions& options) {
  check_mask(input, options);
  std::array<int64_t, 3> lo{}, hi{};
  inside_box(input, lo, hi);
  if (hi[0] < 0) throw invalid_input("mesh_mask_tets: mask", "is empty (no voxel inside)");
  double extent = 0.0;
  for (int a = 0; a < 3; ++a)
    extent = std::max(extent, (hi[a] - lo[a] + 1) * input.frame.spacing_mm[a]);
  const double input_max_spacing =
      std::max({input.frame.spacing_mm[0], input.frame.spacing_mm[1], input.frame.spacing_mm[2]});
  const double cell_size = options.cell_size_mm > 0.0 ? options.cell_size_mm
                                                      : std::max(extent / 15.0, input_max_spacing);

  // A mask finer than about four voxels per cell (a clinical 0.57 mm scan under 8 mm cells) is
  // box-filtered down first, as the model builder does: CGAL's image oracle over 9.5 million
  // voxels took minutes (docs/validation.md).
  const std::array<int, 3> factors =
      geometry::working_grid_factors(input.frame.spacing_mm, cell_size);
  Mask coarse;
  const bool downsample = factors[0] > 1 || factors[1] > 1 || factors[2] > 1;
  if (downsample) {
    // Padded first by a block, so the trailing partial block the filter drops is background.
    coarse = geometry::downsample_mask(
        geometry::pad_mask(input, *std::max_element(factors.begin(), factors.end())), factors);
    inside_box(coarse, lo, hi);
    if (hi[0] < 0)
      throw invalid_input("mesh_mask_tets: mask",
                          fmt::format("vanishes when box-filtered to {:g} mm cells' working grid "
                                      "(too thin for cell size {:g} mm)",
                                      cell_size / 4.0, cell_size));
  }
  const Mask& mask = downsample ? coarse : input;
  const GridFrame& frame = mask.frame;
  const std::array<double, 3>& s = frame.spacing_mm;
  const double max_spacing = std::max({s[0], s[1], s[2]});
  // Half the LARGEST spacing: the interpolated surface of a binary mask carries a staircase
  // about that deep along the coarse axis, and a tighter bound chases it. On a clinical liver
  // (0.57 x 0.57 x 1.6 mm) half the smallest spacing refined the surface for over 6 minutes.
  const double facet_distance =
      options.facet_distance_mm > 0.0 ? options.facet_distance_mm : 0.5 * max_spacing;

  // The cropped, padded mask as an 8-bit CGAL image; CGAL's voxel order is x fastest, like ours.
  // Its coordinates are padded-crop index * spacing. The crop's offset is added back in double
  // when mapping to physical space (CGAL's image translation is a float, which would shift the
  // mesh by up to ~1e-5 mm far from the origin).
  std::array<int64_t, 3> n{};
  for (int a = 0; a < 3; ++a) n[a] = hi[a] - lo[a] + 1 + 2 * kPad;
  _image* im =
      ::_createImage(static_cast<size_t>(n[0]), static_cast<size_t>(n[1]),
                     static_cast<size_t>(n[2]), 1, s[0], s[1], s[2], 1, WK_FIXED, SGN_UNSIGNED);
  if (im == nullptr) throw Error(ErrorKind::kInternal, "mesh_mask_tets: could not allocate image");
  auto* data = static_cast<unsigned char*>(im->data);
  std::fill(data, data + n[0] * n[1] * n[2], static_cast<unsigned char>(0));
  for (int64_t k = lo[2]; k <= hi[2]; ++k)
    for (int64_t j = lo[1]; j <= hi[1]; ++j)
      for (int64_t i = lo[0]; i <= hi[0]; ++i)
        data[(i - lo[0] + kPad) + n[0] * ((j - lo[1] + kPad) + n[1] * (k - lo[2] + kPad))] =
            mask.inside[frame.index(i, j, k)] ? 1 : 0;
  const CGAL::Image_3 image(im);  // takes ownership

  // Determinism: the domain shoots its initial points with its own generator (seeded here),
  // the triangulation's walks and the perturber use fixed-seed generators, the default
  // generator is reseeded in case any other step draws from it, meshing is sequential, and
  // perturbation and exudation run with no time limit (CGAL's default limit is the refinement
  // time, which would make the result depend on the machine's load).
  CGAL::get_default_random() = CGAL::Random(0);
  CGAL::Random rng(0);
  namespace params = CGAL::parameters;
  const Domain domain = Domain::create_labeled_image_mesh_domain(
      image, params::relative_error_bound = 1e-5, params::p_rng = &rng);
  const Criteria criteria(params::facet_angle = options.facet_angle_deg,
                          params::facet_size = cell_size, params::facet_distance = facet_distance,
                          params::cell_radius_edge_ratio = options.cell_radius_edge_ratio,
                          params::cell_size = cell_size);
  C3t3 c3t3;
  try {
    const double sliver = options.sliver_angle_deg;
    if (sliver > 0.0)
      c3t3 = CGAL::make_mesh_3<C3t3>(
          domain, criteria, params::manifold(),
          params::perturb(params::time_limit = 0, params::sliver_bound = sliver),
          params::exude(params::time_limit = 0, params::sliver_bound = sliver));
    else
      c3t3 = CGAL::make_mesh_3<C3t3>(domain, criteria, params::manifold(), params::no_perturb(),
                                     params::no_exude());
  } catch (const std::exception& e) {
    throw Error(ErrorKind::kInternal,
                std::string("mesh_mask_tets: CGAL Mesh_3 failed: ") + e.what());
  }

  // Image space -> physical space: x = origin + D * (crop offset + q).
  Eigen::Matrix3d D;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) D(r, c) = frame.direction[3 * r + c];
  const Eigen::Vector3d origin(frame.origin_mm[0], frame.origin_mm[1], frame.origin_mm[2]);
  const Eigen::Vector3d offset((lo[0] - kPad) * s[0], (lo[1] - kPad) * s[1], (lo[2] - kPad) * s[2]);

  // Keep the cells of the complex, oriented positively in physical space (a direction matrix
  // with determinant -1 flips CGAL's orientation), without flat ones; number their vertices in
  // order of first use.
  const Tr& tr = c3t3.triangulation();
  std::map<Tr::Vertex_handle, int> id;
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector4i> tets;
  tets.reserve(static_cast<size_t>(c3t3.number_of_cells_in_complex()));
  for (auto cell = c3t3.cells_in_complex_begin(); cell != c3t3.cells_in_complex_end(); ++cell) {
    std::array<Eigen::Vector3d, 4> p;
    double longest = 0.0;
    for (int a = 0; a < 4; ++a) {
      const auto& q = tr.point(cell, a).point();
      p[a] = origin + D * (offset + Eigen::Vector3d(q.x(), q.y(), q.z()));
    }
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) longest = std::max(longest, (p[a] - p[b]).norm());
    const double v6 = signed_volume6(p[0], p[1], p[2], p[3]);
    if (!(std::abs(v6) > 1e-12 * longest * longest * longest)) continue;
    std::array<int, 4> order{0, 1, 2, 3};
    if (v6 < 0.0) std::swap(order[2], order[3]);
    Eigen::Vector4i tet;
    for (int a = 0; a < 4; ++a) {
      const Tr::Vertex_handle v = cell->vertex(order[a]);
      auto [it, inserted] = id.emplace(v, static_cast<int>(points.size()));
      if (inserted) points.push_back(p[order[a]]);
      tet[a] = it->second;
    }
    tets.push_back(tet);
  }
  if (tets.empty())
    throw invalid_input(
        "mesh_mask_tets: mask",
        fmt::format("gave no tetrahedra at cell size {:g} mm (the mask is too small "
                    "or thin for it; use a smaller cell_size_mm)",
                    cell_size));

  TetMesh mesh;
  mesh.V.resize(static_cast<Eigen::Index>(points.size()), 3);
  for (size_t v = 0; v < points.size(); ++v) mesh.V.row(static_cast<Eigen::Index>(v)) = points[v];
  mesh.T.resize(static_cast<Eigen::Index>(tets.size()), 4);
  for (size_t t = 0; t < tets.size(); ++t) mesh.T.row(static_cast<Eigen::Index>(t)) = tets[t];
  return mesh;
}

Eigen::MatrixX3i boundary_faces(const TetMesh& mesh) {
  // The four faces of a positively oriented tet (0,1,2,3), wound outward.
  static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  struct Face {
    std::array<int, 3> key;   // sorted vertex ids
    std::array<int, 3> face;  // as wound
  };
  std::vector<Face> faces;
  faces.reserve(static_cast<size_t>(mesh.T.rows()) * 4);
  for (Eigen::Index t = 0; t < mesh.T.rows(); ++t)
    for (const auto& f : kFace) {
      Face face{{}, {mesh.T(t, f[0]), mesh.T(t, f[1]), mesh.T(t, f[2])}};
      face.key = face.face;
      std::sort(face.key.begin(), face.key.end());
      faces.push_back(face);
    }
  std::sort(faces.begin(), faces.end(), [](const Face& a, const Face& b) { return a.key < b.key; });
  std::vector<std::array<int, 3>> out;
  for (size_t i = 0; i < faces.size();) {
    size_t j = i + 1;
    while (j < faces.size() && faces[j].key == faces[i].key) ++j;
    if (j - i == 1) out.push_back(faces[i].face);
    i = j;
  }
  Eigen::MatrixX3i F(static_cast<Eigen::Index>(out.size()), 3);
  for (size_t f = 0; f < out.size(); ++f)
    F.row(static_cast<Eigen::Index>(f)) << out[f][0], out[f][1], out[f][2];
  return F;
}

double tet_volume(const TetMesh& mesh, const Eigen::MatrixX3d& x) {
  if (mesh.T.rows() == 0) return 0.0;
  if (mesh.T.minCoeff() < 0 || mesh.T.maxCoeff() >= x.rows())
    throw invalid_input("tet_volume: x", fmt::format("has {} rows; the tets index {}..{}", x.rows(),
                                                     mesh.T.minCoeff(), mesh.T.maxCoeff()));
  double v6 = 0.0;
  for (Eigen::Index t = 0; t < mesh.T.rows(); ++t)
    v6 += signed_volume6(x.row(mesh.T(t, 0)).transpose(), x.row(mesh.T(t, 1)).transpose(),
                         x.row(mesh.T(t, 2)).transpose(), x.row(mesh.T(t, 3)).transpose());
  return v6 / 6.0;
}

}  // namespace lamina::validate
