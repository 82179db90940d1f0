#pragma once
/// \file
/// Reading a resection surface: a surface file, or a 3D Slicer markups file (a plane or a closed
/// curve).

#include <string>

#include "lamina/geometry/resection_surface.h"

namespace lamina::io {

/// Reads the surface a resection follows, by the file's extension:
///   - .mrk.json / .json: a 3D Slicer markups file holding one Plane (its "center" and "normal",
///     or its control points: one with "baseToNode", or three) or one ClosedCurve (its control
///     points, spanned by a fan: geometry::closed_curve_surface), in its coordinateSystem (LPS,
///     the default, or RAS, turned to LPS)
///   - .obj (our reader), .ply, .stl, .off (CGAL's): triangles, their winding giving the front
/// \note Throws lamina::Error (kInvalidInput) naming `path`: a missing or malformed file, a
///   markups file of another kind ("Fiducial", "Line", an open "Curve", ...) or with more than
///   one markup, a plane without a normal, a curve with fewer than three points.
geometry::ResectionSurface read_resection_surface(const std::string& path);

}  // namespace lamina::io
