#pragma once
/// \file
/// Writing triangle meshes for other tools (MeshLab, ParaView, slicers); reading OBJ and VTP files.

#include <optional>
#include <string>
#include <vector>

#include "lamina/geometry/surface_mesh.h"
#include "lamina/model/structure_colors.h"

namespace lamina::io {

/// Writes `mesh` in the format its extension names (case-insensitive), atomically (temporary
/// file, then rename):
///   - .obj  text, `v x y z` and 1-based `f a b c` lines, doubles in shortest round-trip form
///   - .ply  binary little-endian, float64 x y z, faces as `list uchar int`
///   - .vtp  VTK XML PolyData, ASCII, triangles as Polys
///   - .stl  binary STL, float32, one normal per face computed from its corners
/// @param[in] mesh   #V by 3 vertices (mm) and #F by 3 triangles
/// @param[in] path   destination file
/// @param[in] color  optional: every vertex's colour, as a `color` point array (UInt8 x 3) in
///                   .vtp (ParaView: colour by it with Map Scalars off) and red/green/blue
///                   vertex properties in .ply; OBJ and STL have no colour
/// \note Throws lamina::Error (kInvalidInput) for an unknown extension or a face index outside
///   [0, #V), before anything is written; (kOutput) if the file cannot be written.
void write_mesh(const SurfaceMesh& mesh, const std::string& path,
                const std::optional<model::Rgb8>& color = std::nullopt);

/// Writes line segments (from.row(k) to to.row(k), mm) as VTK XML PolyData Lines with one
/// value per segment (a cell array named `value_name`): a world's ties, drawn in ParaView.
/// \note Throws lamina::Error (kInvalidInput) for another extension than .vtp or sizes that
///   differ; (kOutput) if the file cannot be written.
void write_segments_vtp(const Eigen::MatrixX3d& from, const Eigen::MatrixX3d& to,
                        const std::vector<double>& value, const std::string& value_name,
                        const std::string& path);

/// Reads the vertices and faces of a Wavefront OBJ file.
/// @param[in] path  .obj file
/// @return V (#V by 3) and F (#F by 3, 0-based); polygons with more than three corners are
///   fan-triangulated from their first corner
/// \note Face corners may be written `i`, `i/t`, `i/t/n` or `i//n`; negative indices count back
///   from the last vertex read so far. Lines other than `v` and `f` are ignored. Throws
///   lamina::Error (kInvalidInput) naming `path` (and the line) for a missing file, a malformed
///   `v` or `f` line, an index outside the vertex list, or a file without faces.
SurfaceMesh read_obj(const std::string& path);

/// Reads the points, polygons and triangle strips of a VTK XML PolyData file (.vtp), as VTK,
/// ParaView and 3D Slicer write it: ascii, binary or appended (base64 or raw) data, uncompressed
/// or zlib-compressed, UInt32 or UInt64 headers, either byte order; several pieces are joined.
/// @param[in] path  .vtp file
/// @return V (#V by 3) and F (#F by 3, 0-based); polygons are fan-triangulated from their first
///   corner, strips split into triangles of alternating order (VTK's); verts and lines are skipped
/// \note Throws lamina::Error (kInvalidInput) naming `path` for a missing file, a file that is not
///   VTK XML PolyData or is cut off, an LZ4 or LZMA compressor, corrupt base64 or zlib data, a
///   count that disagrees with the piece, a point that is not finite, a cell naming a point the
///   piece does not have, or a file without polygons or strips.
SurfaceMesh read_vtp(const std::string& path);

}  // namespace lamina::io
