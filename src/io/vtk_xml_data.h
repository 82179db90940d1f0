#pragma once
// Internal (not installed): the data of VTK XML files written by VTK itself (vtkXMLWriter), in
// every encoding it writes: ascii; binary (base64 inline); appended, base64 or raw; each with or
// without zlib compression, UInt32 or UInt64 headers, little- or big-endian. docs/resection.md
// names the files read with it; format: VTK's "VTK File Formats" (XML, binary data section).
#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace lamina::io::detail {

// A VTK XML file's whole text and how its binary data is laid out (from <VTKFile>'s attributes
// and the <AppendedData> element).
struct VtkXmlFrame {
  std::string path;
  std::string_view text;                 // the whole file
  bool big_endian = false;               // byte_order="BigEndian"
  int header_bytes = 4;                  // header_type UInt32 (4) or UInt64 (8)
  bool zlib = false;                     // compressor="vtkZLibDataCompressor"
  std::string_view appended;             // after <AppendedData>'s '_' to </AppendedData>
  bool appended_raw = false;             // encoding="raw" (else base64)
  std::vector<int64_t> appended_starts;  // every array's offset, sorted: where base64 ones end
};

// One <DataArray>: its attributes and its inline text (up to its first child element).
struct VtkXmlArray {
  std::map<std::string, std::string> attributes;
  std::string_view text;
};

// One <Piece>: its attributes and its arrays, keyed "Section/Name" ("Points/Points",
// "Polys/connectivity", "PointData/Normals").
struct VtkXmlPiece {
  std::map<std::string, std::string> attributes;
  std::map<std::string, VtkXmlArray> arrays;
};

struct VtkXmlFile {
  std::string type;  // <VTKFile type=...>: PolyData, UnstructuredGrid, ...
  VtkXmlFrame frame;
  std::vector<VtkXmlPiece> pieces;
};

// Scans `text` (the bytes of `path`): throws lamina::Error (kInvalidInput) naming `path` for a
// file that is not VTK XML, is cut off, has a compressor other than zlib, an unknown header type
// or byte order. Points into `text`; the arrays are decoded later, by the two functions below.
VtkXmlFile scan_vtk_xml(const std::string& path, std::string_view text);

// The `count` values of `a` as doubles (Float32/64 and integer types alike), or as int64 (integer
// types only). Throws lamina::Error (kInvalidInput) naming the file and `what` for any value
// count other than `count`, corrupt base64 or zlib data, data past the file's end, or a type
// VTK does not write.
std::vector<double> vtk_doubles(const VtkXmlFrame& f, const VtkXmlArray& a, size_t count,
                                const std::string& what);
std::vector<int64_t> vtk_integers(const VtkXmlFrame& f, const VtkXmlArray& a, size_t count,
                                  const std::string& what);
// As many values as `a` holds (VTK writes no count for a cell array's offsets), at most `limit`.
inline constexpr size_t kAnyCount = static_cast<size_t>(-1);

}  // namespace lamina::io::detail
