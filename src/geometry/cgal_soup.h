#pragma once
// CGAL's types for the geometry module's few CGAL units, and a mesh as CGAL's polygon soup
// (internal: only sources listed with lamina_cgal_sources include it).
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>

#include <array>
#include <vector>

#include "lamina/geometry/surface_mesh.h"

namespace lamina::geometry::cgal {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;

/// (V, F) as points and index triples.
inline void to_soup(const SurfaceMesh& in, std::vector<Point>& points,
                    std::vector<std::array<size_t, 3>>& faces) {
  points.resize(static_cast<size_t>(in.V.rows()));
  for (Eigen::Index v = 0; v < in.V.rows(); ++v)
    points[v] = Point(in.V(v, 0), in.V(v, 1), in.V(v, 2));
  faces.resize(static_cast<size_t>(in.F.rows()));
  for (Eigen::Index f = 0; f < in.F.rows(); ++f)
    faces[f] = {static_cast<size_t>(in.F(f, 0)), static_cast<size_t>(in.F(f, 1)),
                static_cast<size_t>(in.F(f, 2))};
}

}  // namespace lamina::geometry::cgal
