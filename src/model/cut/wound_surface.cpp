// The wound: the surface a cut opens inside the organ, on each side. In each divided tetrahedron
// the cut is the polygon through its crossings of the edges between the two sides (a triangle
// for one corner against three, a quad for two against two); each side's copy carries that
// polygon, facing out of its material, its corners embedded on the copy's edges. Neighbouring
// copies on one side share their nodes where the cut runs on, so each side's wound is one mesh.
#include <Eigen/Geometry>
#include <array>
#include <unordered_map>

#include "cut_internal.h"

namespace lamina::model::detail {
namespace {

struct WoundBuilder {
  explicit WoundBuilder(EmbeddedSurface& surface) : s(surface) {}

  EmbeddedSurface& s;
  std::vector<Eigen::RowVector3d> V;
  std::vector<Eigen::RowVector4i> corners;
  std::vector<Eigen::RowVector4d> weights;
  std::vector<Eigen::RowVector3i> F;
  std::unordered_map<uint64_t, int32_t> at;  // by the copy's nodes of the crossed edge

  // The crossing of edge (i, j) of copy c of tetrahedron t, fraction f from corner i.
  int32_t vertex(const Eigen::MatrixX3d& X, const Eigen::MatrixX4i& T,
                 const Eigen::MatrixX4i& cut_T, int32_t t, int32_t c, int i, int j, double f) {
    const int32_t a = cut_T(c, i), b = cut_T(c, j);
    const uint64_t key = edge_key(a, b);  // a neighbour may list the edge the other way
    const auto [it, fresh] =
        at.try_emplace(key, static_cast<int32_t>(s.V.rows()) + static_cast<int32_t>(V.size()));
    if (!fresh) return it->second;
    V.push_back((1.0 - f) * X.row(T(t, i)) + f * X.row(T(t, j)));
    corners.push_back(cut_T.row(c));
    Eigen::RowVector4d w = Eigen::RowVector4d::Zero();
    w[i] = 1.0 - f, w[j] = f;
    weights.push_back(w);
    return it->second;
  }
};

}  // namespace

void add_wound(const Eigen::MatrixX3d& X, const Eigen::MatrixX4i& T,
               const std::vector<Division>& divided, const std::vector<int32_t>& first_copy,
               const Crossings& crossings, const Eigen::MatrixX4i& cut_T,
               std::vector<EmbeddedSurface>& embedded) {
  if (divided.empty()) return;
  EmbeddedSurface* wound = nullptr;
  for (EmbeddedSurface& e : embedded)
    if (e.role == SurfaceRole::kWound) wound = &e;
  if (!wound) {
    EmbeddedSurface& e = embedded.emplace_back();
    e.name = kWoundName;
    e.role = SurfaceRole::kWound;
    e.label = 0;
    e.V.resize(0, 3), e.F.resize(0, 3), e.corners.resize(0, 4), e.weights.resize(0, 4);
    wound = &e;
  }
  WoundBuilder b(*wound);
  for (size_t k = 0; k < divided.size(); ++k) {
    const int32_t t = divided[k].tet;
    const uint8_t side = divided[k].side;
    // The polygon's corners in order around it: for two and two (a, b | c, d) ac, ad, bd, bc.
    std::array<std::pair<int, int>, 4> edges{};
    int n = 0;
    int in[4], out[4], ni = 0, no = 0;
    for (int q = 0; q < 4; ++q) (side >> q & 1 ? in[ni++] : out[no++]) = q;
    if (ni == 2) {
      edges = {{{in[0], out[0]}, {in[0], out[1]}, {in[1], out[1]}, {in[1], out[0]}}};
      n = 4;
    } else {
      for (int p = 0; p < ni; ++p)
        for (int q = 0; q < no; ++q) edges[n++] = {in[p], out[q]};
    }
    // Facing out of the side's material: from its corners towards the others'.
    Eigen::Vector3d from = Eigen::Vector3d::Zero(), to = Eigen::Vector3d::Zero();
    for (int p = 0; p < ni; ++p) from += X.row(T(t, in[p])).transpose() / ni;
    for (int q = 0; q < no; ++q) to += X.row(T(t, out[q])).transpose() / no;
    std::array<Eigen::Vector3d, 4> pos;
    std::array<double, 4> frac{};
    for (int e = 0; e < n; ++e) {
      const auto [i, j] = edges[e];
      frac[e] = crossings.fraction(T(t, i), T(t, j));
      pos[e] = (1.0 - frac[e]) * X.row(T(t, i)).transpose() + frac[e] * X.row(T(t, j)).transpose();
    }
    const Eigen::Vector3d normal = n == 4 ? (pos[2] - pos[0]).cross(pos[3] - pos[1])
                                          : (pos[1] - pos[0]).cross(pos[2] - pos[0]);
    const bool flip = normal.dot(to - from) < 0.0;
    for (int copy = 0; copy < 2; ++copy) {
      const int32_t c = first_copy[k] + copy;  // the side's copy, then the other's
      std::array<int32_t, 4> v{};
      for (int e = 0; e < n; ++e) {
        const auto [i, j] = edges[e];
        v[e] = b.vertex(X, T, cut_T, t, c, i, j, frac[e]);
      }
      // The side's copy faces the other side; the other's faces back.
      const bool reverse = flip != (copy == 1);
      auto tri = [&](int p, int q, int r) {
        b.F.push_back(reverse ? Eigen::RowVector3i(v[p], v[r], v[q])
                              : Eigen::RowVector3i(v[p], v[q], v[r]));
      };
      tri(0, 1, 2);
      if (n == 4) tri(0, 2, 3);
    }
  }
  const auto grow = [](auto& m, const auto& rows) {
    const Eigen::Index r0 = m.rows();
    m.conservativeResize(r0 + static_cast<Eigen::Index>(rows.size()), Eigen::NoChange);
    for (size_t k = 0; k < rows.size(); ++k) m.row(r0 + static_cast<Eigen::Index>(k)) = rows[k];
  };
  grow(wound->V, b.V);
  grow(wound->corners, b.corners);
  grow(wound->weights, b.weights);
  grow(wound->F, b.F);  // no offsets: every vertex lies on its copy's edge
}

}  // namespace lamina::model::detail
