#include "lamina/geometry/mesh_measures.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace lamina::geometry {

double enclosed_volume(const SurfaceMesh& m) {
  double v6 = 0.0;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    v6 += m.V.row(m.F(f, 0)).dot(m.V.row(m.F(f, 1)).cross(m.V.row(m.F(f, 2))));
  return v6 / 6.0;
}

double surface_area(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) {
  double area = 0.0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    area += 0.5 * (b - a).cross(c - a).norm();
  }
  return area;
}

std::vector<std::pair<int, int>> mesh_edges(const Eigen::MatrixX3i& F) {
  std::vector<std::pair<int, int>> e;
  e.reserve(static_cast<size_t>(F.rows()) * 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int a = F(f, c), b = F(f, (c + 1) % 3);
      e.emplace_back(std::min(a, b), std::max(a, b));
    }
  std::sort(e.begin(), e.end());
  e.erase(std::unique(e.begin(), e.end()), e.end());
  return e;
}

std::vector<int> face_components(const Eigen::MatrixX3i& F, Eigen::Index vertex_count, int& count) {
  std::vector<int> parent(static_cast<size_t>(vertex_count));
  for (size_t v = 0; v < parent.size(); ++v) parent[v] = static_cast<int>(v);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 1; c < 3; ++c) parent[find(F(f, c))] = find(F(f, 0));
  std::vector<int> id_of_root(parent.size(), -1);
  std::vector<int> comp(static_cast<size_t>(F.rows()));
  count = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const int r = find(F(f, 0));
    if (id_of_root[r] < 0) id_of_root[r] = count++;
    comp[f] = id_of_root[r];
  }
  return comp;
}

std::vector<SurfaceMesh> split_components(const SurfaceMesh& in) {
  int count = 0;
  const std::vector<int> comp = face_components(in.F, in.V.rows(), count);
  // Component of each vertex, then local indices in the original vertex order.
  std::vector<int> vcomp(static_cast<size_t>(in.V.rows()), -1), local(vcomp.size(), -1);
  for (Eigen::Index f = 0; f < in.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) vcomp[in.F(f, k)] = comp[f];
  std::vector<Eigen::Index> nv(static_cast<size_t>(count), 0), nf(static_cast<size_t>(count), 0);
  for (size_t v = 0; v < vcomp.size(); ++v)
    if (vcomp[v] >= 0) local[v] = static_cast<int>(nv[vcomp[v]]++);
  for (int c : comp) ++nf[c];
  std::vector<SurfaceMesh> out(static_cast<size_t>(count));
  for (int c = 0; c < count; ++c) out[c].V.resize(nv[c], 3), out[c].F.resize(nf[c], 3);
  for (size_t v = 0; v < vcomp.size(); ++v)
    if (vcomp[v] >= 0) out[vcomp[v]].V.row(local[v]) = in.V.row(static_cast<Eigen::Index>(v));
  std::fill(nf.begin(), nf.end(), 0);
  for (Eigen::Index f = 0; f < in.F.rows(); ++f) {
    const int c = comp[f];
    for (int k = 0; k < 3; ++k) out[c].F(nf[c], k) = local[in.F(f, k)];
    ++nf[c];
  }
  return out;
}

SurfaceMesh largest_piece(const SurfaceMesh& mesh, int* pieces) {
  std::vector<SurfaceMesh> parts = split_components(mesh);
  if (pieces) *pieces = static_cast<int>(parts.size());
  if (parts.size() <= 1) return mesh;
  double best = -std::numeric_limits<double>::infinity();
  size_t keep = 0;
  for (size_t p = 0; p < parts.size(); ++p) {
    const double v = enclosed_volume(parts[p]);
    if (v > best) best = v, keep = p;
  }
  return std::move(parts[keep]);
}

SurfaceMesh merge_meshes(const std::vector<SurfaceMesh>& meshes) {
  SurfaceMesh out;
  Eigen::Index nv = 0, nf = 0;
  for (const auto& m : meshes) nv += m.V.rows(), nf += m.F.rows();
  out.V.resize(nv, 3);
  out.F.resize(nf, 3);
  Eigen::Index v0 = 0, f0 = 0;
  for (const auto& m : meshes) {
    out.V.middleRows(v0, m.V.rows()) = m.V;
    out.F.middleRows(f0, m.F.rows()) = m.F.array() + static_cast<int>(v0);
    v0 += m.V.rows();
    f0 += m.F.rows();
  }
  return out;
}

MeshQuality measure_mesh(const SurfaceMesh& m) {
  MeshQuality q;
  q.vertices = m.V.rows();
  q.faces = m.F.rows();
  if (q.faces == 0) return q;

  // Directed half-edges, sorted: a closed, consistently oriented manifold has every directed
  // edge once and its twin once.
  std::vector<std::pair<int, int>> half;
  half.reserve(static_cast<size_t>(q.faces) * 3);
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    for (int c = 0; c < 3; ++c) half.emplace_back(m.F(f, c), m.F(f, (c + 1) % 3));
  std::sort(half.begin(), half.end());
  bool consistent = std::adjacent_find(half.begin(), half.end()) == half.end();
  bool closed = true;
  for (const auto& [a, b] : half)
    if (!std::binary_search(half.begin(), half.end(), std::make_pair(b, a))) closed = false;

  // One fan per vertex: the link edges (opposite each vertex) must form a single cycle.
  bool fans_ok = true;
  {
    std::vector<std::vector<std::pair<int, int>>> link(static_cast<size_t>(q.vertices));
    for (Eigen::Index f = 0; f < m.F.rows(); ++f)
      for (int c = 0; c < 3; ++c)
        link[m.F(f, c)].emplace_back(m.F(f, (c + 1) % 3), m.F(f, (c + 2) % 3));
    for (auto& l : link) {
      if (l.empty()) continue;
      // Walk next = the link edge starting where the previous ended.
      std::sort(l.begin(), l.end());
      size_t steps = 0;
      int at = l.front().second;
      const int start = l.front().first;
      while (at != start && steps <= l.size()) {
        auto it = std::lower_bound(l.begin(), l.end(),
                                   std::make_pair(at, std::numeric_limits<int>::min()));
        if (it == l.end() || it->first != at) break;
        at = it->second;
        ++steps;
      }
      if (at != start || steps + 1 != l.size()) fans_ok = false;
    }
  }
  q.closed = closed && consistent;
  q.manifold = consistent && fans_ok;

  double edge_sum = 0.0;
  size_t edge_count = 0;
  q.min_edge_mm = std::numeric_limits<double>::infinity();
  double min_angle = std::numbers::pi;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const Eigen::RowVector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    const double area = 0.5 * (b - a).cross(c - a).norm();
    q.area_mm2 += area;
    const double l[3] = {(b - c).norm(), (c - a).norm(), (a - b).norm()};
    const double lmax = std::max({l[0], l[1], l[2]});
    if (area <= 1e-8 * lmax * lmax) ++q.degenerate_faces;
    for (int k = 0; k < 3; ++k) {
      edge_sum += l[k];
      ++edge_count;
      q.min_edge_mm = std::min(q.min_edge_mm, l[k]);
      q.max_edge_mm = std::max(q.max_edge_mm, l[k]);
      // Law of cosines for the angle opposite edge k.
      const double u = l[(k + 1) % 3], w = l[(k + 2) % 3];
      if (u > 0 && w > 0) {
        const double cosine = std::clamp((u * u + w * w - l[k] * l[k]) / (2 * u * w), -1.0, 1.0);
        min_angle = std::min(min_angle, std::acos(cosine));
      } else {
        min_angle = 0.0;
      }
    }
  }
  q.mean_edge_mm =
      edge_sum / static_cast<double>(edge_count);  // interior edges counted twice: same mean
  q.min_angle_deg = min_angle * 180.0 / std::numbers::pi;
  q.volume_mm3 = enclosed_volume(m);
  q.outward = q.volume_mm3 > 0.0;
  face_components(m.F, m.V.rows(), q.components);
  return q;
}

}  // namespace lamina::geometry
