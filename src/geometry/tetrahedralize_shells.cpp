// TetGen 1.5 behind Lamina's plain arrays: the only translation unit that includes tetgen.h.
#include "lamina/geometry/tetrahedralize_shells.h"

#define TETLIBRARY
#include <fmt/format.h>
#include <tetgen.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <map>
#include <string>
#include <unordered_map>

#include "lamina/core/error.h"

namespace lamina::geometry {
namespace {

Error failed(const std::string& problem) {
  return Error(ErrorKind::kInternal,
               "tetrahedral meshing of the layers failed: " + problem +
                   " (layers too close to each other; try fewer --layers or a larger "
                   "--layer-depth)");
}

// A triangle's corners, sorted: the key of a face shared by two tetrahedra.
using FaceKey = std::array<int, 3>;
struct FaceHash {
  size_t operator()(const FaceKey& k) const {
    return (static_cast<size_t>(k[0]) * 73856093u) ^ (static_cast<size_t>(k[1]) * 19349663u) ^
           (static_cast<size_t>(k[2]) * 83492791u);
  }
};
FaceKey key(int a, int b, int c) {
  FaceKey k{a, b, c};
  std::sort(k.begin(), k.end());
  return k;
}

}  // namespace

ShellTets tetrahedralize_shells(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                const std::vector<int32_t>& surface, const TetOptions& options) {
  if (static_cast<Eigen::Index>(surface.size()) != F.rows())
    throw Error(ErrorKind::kInternal, "tetrahedralize_shells: one surface index per triangle");
  const int np = static_cast<int>(V.rows()), nf = static_cast<int>(F.rows());

  // The input: every vertex, and every triangle as a one-polygon facet. tetgenio frees these
  // arrays itself (with delete[]).
  tetgenio in, out;
  in.firstnumber = 0;
  in.numberofpoints = np;
  in.pointlist = new REAL[3 * static_cast<size_t>(np)];
  for (int i = 0; i < np; ++i)
    for (int c = 0; c < 3; ++c) in.pointlist[3 * i + c] = V(i, c);
  in.numberoffacets = nf;
  in.facetlist = new tetgenio::facet[nf];
  in.facetmarkerlist = new int[nf];
  for (int f = 0; f < nf; ++f) {
    tetgenio::facet& facet = in.facetlist[f];
    tetgenio::init(&facet);
    facet.numberofpolygons = 1;
    facet.polygonlist = new tetgenio::polygon[1];
    tetgenio::init(&facet.polygonlist[0]);
    facet.polygonlist[0].numberofvertices = 3;
    facet.polygonlist[0].vertexlist = new int[3]{F(f, 0), F(f, 1), F(f, 2)};
    in.facetmarkerlist[f] = surface[static_cast<size_t>(f)] + 1;
  }

  // TetGen assumes its input does not intersect itself (and crashes on crossing surfaces): -d
  // first checks, listing the intersecting facets; a caller that has checked the surfaces
  // (build_model(), with CGAL) turns it off.
  if (options.check_intersections) {
    tetgenio check;
    std::string detect = "dQ";
    try {
      tetrahedralize(detect.data(), &in, &check);
    } catch (int code) {
      throw failed(fmt::format("TetGen's intersection check stopped with code {}", code));
    }
    if (check.numberoftrifaces > 0)
      throw failed(
          fmt::format("{} triangles of the layers intersect each other", check.numberoftrifaces));
  }

  // -p: the input is a piecewise linear complex; -Y: no Steiner point on its facets, so the
  // layers stay exactly as they are; -q: radius-edge and dihedral bounds; -A: one attribute per
  // region enclosed by facets; -Q: quiet.
  std::string switches =
      fmt::format("pYq{:.3g}/{:.3g}AQ", options.max_radius_edge_ratio, options.min_dihedral_deg);
  try {
    tetrahedralize(switches.data(), &in, &out);
  } catch (int code) {
    throw failed(fmt::format("TetGen stopped with code {}", code));
  }
  if (out.numberoftetrahedra <= 0 || out.numberofcorners != 4 || out.numberofpoints < np ||
      out.numberoftetrahedronattributes < 1)
    throw failed("TetGen returned no usable tetrahedra");
  for (int i = 0; i < np; ++i)
    for (int c = 0; c < 3; ++c)
      if (out.pointlist[3 * i + c] != V(i, c))
        throw failed(fmt::format("TetGen moved or merged input vertex {}", i));

  ShellTets result;
  const int extra = out.numberofpoints - np;
  result.interior_points.resize(extra, 3);
  for (int p = 0; p < extra; ++p)
    for (int c = 0; c < 3; ++c) result.interior_points(p, c) = out.pointlist[3 * (np + p) + c];
  const auto point = [&](int i) {
    return Eigen::Vector3d(out.pointlist[3 * i], out.pointlist[3 * i + 1],
                           out.pointlist[3 * i + 2]);
  };
  const int nt = out.numberoftetrahedra;
  result.T.resize(nt, 4);
  std::unordered_map<FaceKey, std::array<int, 2>, FaceHash> tets_of_face;
  tets_of_face.reserve(4 * static_cast<size_t>(nt));
  for (int t = 0; t < nt; ++t) {
    int q[4];
    for (int c = 0; c < 4; ++c) q[c] = out.tetrahedronlist[4 * t + c];
    const double volume =
        (point(q[1]) - point(q[0])).cross(point(q[2]) - point(q[0])).dot(point(q[3]) - point(q[0]));
    if (volume < 0.0) std::swap(q[1], q[2]);
    for (int c = 0; c < 4; ++c) result.T(t, c) = q[c];
    for (int c = 0; c < 4; ++c) {
      auto [it, added] = tets_of_face.try_emplace(
          key(q[(c + 1) % 4], q[(c + 2) % 4], q[(c + 3) % 4]), std::array<int, 2>{t, -1});
      if (!added) it->second[1] = t;
    }
  }

  // Each region TetGen numbered lies just inside the surfaces whose triangles it touches from
  // their inner side; it must be one surface (a shell is bounded outside by one layer).
  std::map<double, int32_t> region_of_attribute;
  for (int f = 0; f < nf; ++f) {
    const auto it = tets_of_face.find(key(F(f, 0), F(f, 1), F(f, 2)));
    if (it == tets_of_face.end())
      throw failed(fmt::format("triangle {} of layer {} is not a face of the tetrahedral mesh", f,
                               surface[static_cast<size_t>(f)]));
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    const Eigen::Vector3d normal = (b - a).cross(c - a);  // outward
    int inside = 0;
    for (int t : it->second) {
      if (t < 0) continue;
      int apex = -1;
      for (int k = 0; k < 4; ++k) {
        const int v = result.T(t, k);
        if (v != F(f, 0) && v != F(f, 1) && v != F(f, 2)) apex = v;
      }
      if ((point(apex) - a).dot(normal) >= 0.0) continue;  // outside this surface
      ++inside;
      const double attribute = out.tetrahedronattributelist[t];
      const int32_t k = surface[static_cast<size_t>(f)];
      const auto [at, added] = region_of_attribute.try_emplace(attribute, k);
      if (!added && at->second != k)
        throw failed(
            fmt::format("one region lies inside both layer {} and layer {}", at->second, k));
    }
    if (inside != 1)
      throw failed(fmt::format("triangle {} of layer {} has {} tetrahedra on its inner side", f,
                               surface[static_cast<size_t>(f)], inside));
  }
  result.region.resize(static_cast<size_t>(nt));
  for (int t = 0; t < nt; ++t) {
    const auto it = region_of_attribute.find(out.tetrahedronattributelist[t]);
    if (it == region_of_attribute.end())
      throw failed("a region of tetrahedra touches no layer from inside");
    result.region[static_cast<size_t>(t)] = it->second;
  }
  return result;
}

}  // namespace lamina::geometry
