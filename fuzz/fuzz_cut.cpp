// Fuzzes the cut (model::sweep_blade, model::cut_tetrahedra, model::to_rest): any bytes are a
// blade - a path of up to six points, a direction and a depth, as doubles, through a small block
// of tetrahedra carrying a sphere (a fine surface the cut splits with CGAL), the path drawn on the
// block moved by a bytes-given shift - and give a cut that keeps the block's mass and material
// volume and leaves the sphere a valid embedded mesh, or a lamina::Error; nothing else.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <vector>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/model/cut_tetrahedra.h"
#include "lamina/model/embed_surface.h"

namespace {

using namespace lamina;

// A 4 x 4 x 4 block of 10 mm cubes, each in six tetrahedra around its diagonal; its springs are
// the edges, its masses a quarter of each tetrahedron's. No layers, no rings: the cut's own work.
const Model& block() {
  static const Model m = [] {
    Model b;
    constexpr int n = 5;
    const auto id = [](int i, int j, int k) { return (k * n + j) * n + i; };
    b.X.resize(n * n * n, 3);
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) b.X.row(id(i, j, k)) << 10.0 * i, 10.0 * j, 10.0 * k;
    static constexpr int kCube[6][4][3] = {
        {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {1, 1, 1}}, {{0, 0, 0}, {1, 1, 0}, {0, 1, 0}, {1, 1, 1}},
        {{0, 0, 0}, {0, 1, 0}, {0, 1, 1}, {1, 1, 1}}, {{0, 0, 0}, {0, 1, 1}, {0, 0, 1}, {1, 1, 1}},
        {{0, 0, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}}, {{0, 0, 0}, {1, 0, 1}, {1, 0, 0}, {1, 1, 1}}};
    std::vector<Eigen::Vector4i> tets;
    for (int k = 0; k + 1 < n; ++k)
      for (int j = 0; j + 1 < n; ++j)
        for (int i = 0; i + 1 < n; ++i)
          for (const auto& t : kCube) {
            Eigen::Vector4i q;
            for (int c = 0; c < 4; ++c) q[c] = id(i + t[c][0], j + t[c][1], k + t[c][2]);
            const Eigen::Vector3d p0 = b.X.row(q[0]);
            const double v = (b.X.row(q[1]).transpose() - p0)
                                 .cross(b.X.row(q[2]).transpose() - p0)
                                 .dot(b.X.row(q[3]).transpose() - p0);
            if (v < 0) std::swap(q[2], q[3]);
            tets.push_back(q);
          }
    b.tets.T.resize(static_cast<Eigen::Index>(tets.size()), 4);
    for (size_t t = 0; t < tets.size(); ++t) b.tets.T.row(static_cast<Eigen::Index>(t)) = tets[t];
    b.tets.region.assign(tets.size(), 0);
    b.layer_of.assign(n * n * n, kInteriorNode);
    b.fixed.assign(n * n * n, 0);
    b.mass_kg.assign(n * n * n, 0.0);
    std::vector<std::pair<int32_t, int32_t>> edges;
    for (const auto& q : tets) {
      for (int c = 0; c < 4; ++c) b.mass_kg[q[c]] += 1e-6 * 1000.0 / 6.0 / 4.0;
      for (int a = 0; a < 4; ++a)
        for (int c = a + 1; c < 4; ++c)
          edges.emplace_back(std::min(q[a], q[c]), std::max(q[a], q[c]));
    }
    std::sort(edges.begin(), edges.end());
    edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
    for (const auto& [i, j] : edges) {
      b.springs.i.push_back(i), b.springs.j.push_back(j);
      b.springs.rest_length_mm.push_back((b.X.row(i) - b.X.row(j)).norm());
      b.springs.stiffness_n_per_m.push_back(1.0);
      b.springs.kind.push_back(SpringKind::kVolume);
    }
    // A sphere of radius 14 mm about the block's centre: an octahedron divided three times.
    std::vector<Eigen::Vector3d> V{{1, 0, 0},  {-1, 0, 0}, {0, 1, 0},
                                   {0, -1, 0}, {0, 0, 1},  {0, 0, -1}};
    std::vector<Eigen::Vector3i> F{{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                   {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
    for (int round = 0; round < 3; ++round) {
      std::map<std::pair<int, int>, int> mid;
      const auto half = [&](int a, int b) {
        const auto [it, fresh] = mid.try_emplace({std::min(a, b), std::max(a, b)}, 0);
        if (fresh) it->second = static_cast<int>(V.size()), V.push_back((V[a] + V[b]).normalized());
        return it->second;
      };
      std::vector<Eigen::Vector3i> next;
      for (const Eigen::Vector3i& f : F) {
        const int ab = half(f[0], f[1]), bc = half(f[1], f[2]), ca = half(f[2], f[0]);
        next.insert(next.end(), {{f[0], ab, ca}, {ab, f[1], bc}, {ca, bc, f[2]}, {ab, bc, ca}});
      }
      F = std::move(next);
    }
    Eigen::MatrixX3d SV(static_cast<Eigen::Index>(V.size()), 3);
    Eigen::MatrixX3i SF(static_cast<Eigen::Index>(F.size()), 3);
    for (size_t v = 0; v < V.size(); ++v)
      SV.row(static_cast<Eigen::Index>(v)) =
          (Eigen::Vector3d::Constant(20.0) + 14.0 * V[v]).transpose();
    for (size_t f = 0; f < F.size(); ++f) SF.row(static_cast<Eigen::Index>(f)) = F[f].transpose();
    b.embedded.push_back(model::embed_surface(b, SV, SF, "sphere", SurfaceRole::kStructure, 1));
    return b;
  }();
  return m;
}

// The cut's surfaces stay meshes the viewer can draw: every triangle names three different
// vertices the surface has, every vertex is finite and embedded in nodes the model has.
bool valid(const Model& m) {
  for (const EmbeddedSurface& s : m.embedded) {
    if (s.corners.rows() != s.V.rows() || s.weights.rows() != s.V.rows()) return false;
    if (s.offsets.rows() != 0 && s.offsets.rows() != s.V.rows()) return false;
    if (!s.V.allFinite() || !s.weights.allFinite()) return false;
    if (s.corners.size() > 0 &&
        (s.corners.minCoeff() < 0 || s.corners.maxCoeff() >= m.node_count()))
      return false;
    for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
      const Eigen::Vector3i t = s.F.row(f);
      if (t.minCoeff() < 0 || t.maxCoeff() >= s.V.rows() || t[0] == t[1] || t[1] == t[2] ||
          t[0] == t[2])
        return false;
    }
  }
  return true;
}

double total(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x;
  return s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  lamina::log::set_verbosity(-1);
  std::vector<double> d(size / sizeof(double));
  if (!d.empty()) std::memcpy(d.data(), data, d.size() * sizeof(double));
  if (d.size() < 7) return 0;
  // d: shift (3), direction (3), depth, then path points (3 each, at most six).
  const Model& m = block();
  const Eigen::Vector3d shift(d[0], d[1], d[2]), dir(d[3], d[4], d[5]);
  std::vector<Eigen::Vector3d> path;
  for (size_t k = 7; k + 2 < d.size() && path.size() < 6; k += 3)
    path.emplace_back(d[k], d[k + 1], d[k + 2]);
  try {
    Eigen::MatrixX3d x = m.X;
    x.rowwise() += shift.transpose();
    const model::Blade drawn = model::sweep_blade(path, dir, d[6]);
    model::Blade rest{model::to_rest(m, x, drawn.V), drawn.F};
    Model cut;
    std::vector<int32_t> origin;
    model::CutReport report;
    model::cut_tetrahedra(m, m.X, rest, cut, origin, report);
    const double m0 = total(m.mass_kg), m1 = total(cut.mass_kg);
    if (!(std::abs(m1 - m0) <= 1e-9 * m0) || origin.size() != static_cast<size_t>(cut.node_count()))
      std::abort();  // a cut that loses mass or nodes is a bug
    double pieces = 0.0;
    for (const model::CutPiece& p : report.pieces) pieces += p.volume_mm3;
    if (!(std::abs(pieces - 64000.0) <= 1e-6 * 64000.0)) std::abort();
    if (!valid(cut)) std::abort();  // a surface the cut left broken
  } catch (const lamina::Error&) {
  }
  return 0;
}
