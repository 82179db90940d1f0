#pragma once
/// \file
/// Isosurfaces of a signed distance field, through OpenVDB's volumeToMesh.

#include "lamina/core/grid.h"
#include "lamina/geometry/surface_mesh.h"

namespace lamina::geometry {

/// Extracts the surface phi = iso_mm as a triangle mesh in physical space.
/// @param[in] field   signed distance, mm, negative inside
/// @param[in] iso_mm  level to extract: 0 is the boundary, -d is the surface d mm inside it
/// @param[in] adaptivity  0 = uniform voxel-sized polygons; up to 1 merges polygons in flat
///   regions (OpenVDB's adaptivity), which shrinks the mesh without moving it off the surface
/// @return watertight triangles (OpenVDB's quads split along their shorter diagonal), wound so
///   that normals point to increasing phi (outward); empty when the level is not crossed
SurfaceMesh extract_isosurface(const DistanceField& field, double iso_mm, double adaptivity = 0.0);

}  // namespace lamina::geometry
