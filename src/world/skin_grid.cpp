// The skin's triangles in a hashed uniform grid, rebuilt every step in place: a radix of
// (bucket, triangle) keys sorted once, so the step allocates nothing once the buffers have grown.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "lamina/geometry/closest_on_triangle.h"
#include "world_work.h"

namespace lamina::world::detail {
namespace {

uint64_t hash_cell(int64_t i, int64_t j, int64_t k) {
  return static_cast<uint64_t>(i) * 73856093ULL ^ static_cast<uint64_t>(j) * 19349663ULL ^
         static_cast<uint64_t>(k) * 83492791ULL;
}

int64_t cell_of(double v, double cell) {
  return static_cast<int64_t>(std::floor(v / cell));
}

}  // namespace

uint64_t grid_bucket(const SkinGrid& grid, const Eigen::Vector3d& p) {
  return hash_cell(cell_of(p.x(), grid.cell_mm), cell_of(p.y(), grid.cell_mm),
                   cell_of(p.z(), grid.cell_mm)) &
         grid.mask;
}

double skin_mean_edge(const Model& model) {
  const Eigen::MatrixX3i& F = model.layers.front().F;
  double sum = 0.0;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    sum += (model.X.row(F(f, 0)) - model.X.row(F(f, 1))).norm();
  return F.rows() > 0 ? sum / static_cast<double>(F.rows()) : 1.0;
}

void build_skin_grid(const Model& model, const Eigen::MatrixX3d& x, double reach_mm,
                     SkinGrid& grid) {
  const Eigen::MatrixX3i& F = model.layers.front().F;
  if (grid.mean_edge_mm <= 0.0) grid.mean_edge_mm = skin_mean_edge(model);
  // Cells of about two edges: a triangle grown by the reach covers a few of them.
  grid.cell_mm = std::max(2.0 * grid.mean_edge_mm, 2.0 * reach_mm);
  uint64_t buckets = 64;
  while (buckets < 2 * static_cast<uint64_t>(F.rows())) buckets *= 2;
  grid.mask = buckets - 1;
  grid.lo.setConstant(std::numeric_limits<double>::infinity());
  grid.hi.setConstant(-std::numeric_limits<double>::infinity());
  // Two passes over every triangle's cells, a counting sort by bucket: the first counts, the
  // second places (a comparison sort of (bucket, triangle) keys took a fifth of a three-organ
  // world's step). A triangle two of whose cells hash to one bucket is placed there once.
  grid.start.assign(buckets + 1, 0);
  grid.fill.resize(buckets);
  for (int pass = 0; pass < 2; ++pass) {
    for (Eigen::Index f = 0; f < F.rows(); ++f) {
      Eigen::Vector3d lo = x.row(F(f, 0)).transpose(), hi = lo;
      for (int c = 1; c < 3; ++c) {
        lo = lo.cwiseMin(x.row(F(f, c)).transpose());
        hi = hi.cwiseMax(x.row(F(f, c)).transpose());
      }
      if (pass == 0) {
        grid.lo = grid.lo.cwiseMin(lo);
        grid.hi = grid.hi.cwiseMax(hi);
      }
      lo.array() -= reach_mm;
      hi.array() += reach_mm;
      const int64_t i0 = cell_of(lo.x(), grid.cell_mm), i1 = cell_of(hi.x(), grid.cell_mm);
      const int64_t j0 = cell_of(lo.y(), grid.cell_mm), j1 = cell_of(hi.y(), grid.cell_mm);
      const int64_t k0 = cell_of(lo.z(), grid.cell_mm), k1 = cell_of(hi.z(), grid.cell_mm);
      for (int64_t i = i0; i <= i1; ++i)
        for (int64_t j = j0; j <= j1; ++j)
          for (int64_t k = k0; k <= k1; ++k) {
            const uint64_t b = hash_cell(i, j, k) & grid.mask;
            if (pass == 0) {
              ++grid.start[b + 1];
              continue;
            }
            int32_t& at = grid.fill[b];
            if (at > grid.start[b] && grid.items[static_cast<size_t>(at - 1)] == f) continue;
            grid.items[static_cast<size_t>(at++)] = static_cast<int32_t>(f);
          }
    }
    if (pass == 0) {
      for (size_t b = 0; b < buckets; ++b) grid.start[b + 1] += grid.start[b];
      grid.items.resize(static_cast<size_t>(grid.start[buckets]));
      std::copy(grid.start.begin(), grid.start.end() - 1, grid.fill.begin());
    }
  }
  // Buckets end where their placing ended (a repeated triangle leaves its slot unused): the
  // query reads [start[b], end[b]).
  grid.end.assign(grid.fill.begin(), grid.fill.end());
}

bool own_neighbourhood(const Model& model, int32_t f, int32_t node, double exclusion_mm) {
  const Eigen::MatrixX3i& F = model.layers.front().F;
  const int32_t i = F(f, 0), j = F(f, 1), k = F(f, 2);
  if (i == node || j == node || k == node) return true;
  const double excl2 = exclusion_mm * exclusion_mm;
  const Eigen::RowVector3d r = model.X.row(node);
  return (model.X.row(i) - r).squaredNorm() < excl2 || (model.X.row(j) - r).squaredNorm() < excl2 ||
         (model.X.row(k) - r).squaredNorm() < excl2;
}

bool nearer_triangle(const Eigen::MatrixX3i& F, const Eigen::MatrixX3d& x, int32_t f,
                     const Eigen::Vector3d& p, double& best, Contact& contact) {
  const int32_t i = F(f, 0), j = F(f, 1), k = F(f, 2);
  const Eigen::Vector3d a = x.row(i).transpose(), b = x.row(j).transpose(),
                        c = x.row(k).transpose();
  // The triangle's box is no nearer than the best so far: most of a bucket's triangles (it
  // holds every one within reach of its cell) end here, before the exact distance.
  const Eigen::Vector3d lo = a.cwiseMin(b).cwiseMin(c), hi = a.cwiseMax(b).cwiseMax(c);
  if ((lo - p).cwiseMax(p - hi).cwiseMax(0.0).squaredNorm() >= best) return false;
  const Eigen::Vector3d w = geometry::closest_on_triangle(p, a, b, c);
  const Eigen::Vector3d q = w.x() * a + w.y() * b + w.z() * c;
  const double d2 = (p - q).squaredNorm();
  if (d2 >= best) return false;
  const Eigen::Vector3d nrm = (b - a).cross(c - a);
  const double len = nrm.norm();
  if (len <= 0.0) return false;
  best = d2;
  contact.corners = {i, j, k};
  contact.weights = w;
  contact.normal = nrm / len;
  // Signed: > 0 behind the triangle (inside the skin).
  const double s = (p - q).dot(contact.normal);
  contact.depth_mm = s < 0.0 ? std::sqrt(d2) : -std::sqrt(d2);
  return true;
}

bool nearest_on_skin(const Model& other_model, const Eigen::MatrixX3d& other_x,
                     const SkinGrid& grid, const Eigen::Vector3d& p, int32_t node, bool self,
                     const Model& node_model, double exclusion_mm, double reach_mm,
                     Contact& contact) {
  const Eigen::MatrixX3i& F = other_model.layers.front().F;
  const uint64_t b = grid_bucket(grid, p);
  double best = reach_mm * reach_mm;
  bool found = false;
  for (int32_t n = grid.start[b]; n < grid.end[b]; ++n) {
    const int32_t f = grid.items[static_cast<size_t>(n)];
    if (self && own_neighbourhood(node_model, f, node, exclusion_mm)) continue;
    found |= nearer_triangle(F, other_x, f, p, best, contact);
  }
  return found;
}

}  // namespace lamina::world::detail
