#pragma once
// Internal (not installed): the pieces of the model file (.vtu, docs/model_format.md) that
// model_file.cpp (nodes, layers, springs, tetrahedra) and model_file_embedded.cpp (the embedded
// surfaces, format version 3) share: the arrays of the one Piece, the VTK XML scanner and array
// reader, and the walk over the cells.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <map>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "lamina/model/model.h"

namespace lamina::io::detail {

constexpr uint8_t kVtkLine = 3;
constexpr uint8_t kVtkTriangle = 5;
constexpr uint8_t kVtkTetra = 10;
constexpr uint8_t kCellKindTriangle = 0;  // springs are 1 + SpringKind
constexpr uint8_t kCellKindTetra = 4;
constexpr uint8_t kCellKindEmbeddedTriangle = 5;
// PointData `layer` of an embedded surface's vertex: a point of the file that is no node of the
// model (Model::layer_of never holds it; kInteriorNode is -1).
constexpr int32_t kEmbeddedVertexLayer = -2;

// The arrays of the Piece as the file holds them: one entry (points: three) per point, then per
// cell. save_model() fills them from the model; load_model() reads them back.
struct PieceArrays {
  std::vector<double> points;  // x y z of each point
  std::vector<int32_t> point_layer;
  std::vector<double> mass_kg;
  std::vector<uint8_t> fixed;
  std::vector<int64_t> connectivity, offsets;  // VTK's: offsets[c] is where cell c's nodes end
  std::vector<uint8_t> types, cell_kind;
  std::vector<int32_t> cell_layer;
  std::vector<double> rest_length, stiffness;

  void add_cell(uint8_t type, uint8_t kind, int32_t layer, std::initializer_list<int64_t> nodes,
                double rest = 0.0, double k = 0.0);
};

// Writes one DataArray. Field data has no points or cells to count its tuples by, so VTK wants
// NumberOfTuples there. Defined for double, int64_t, int32_t and uint8_t.
template <class T>
void write_array(std::ostream& out, const char* indent, const std::string& name,
                 const std::vector<T>& values, size_t components = 1, bool field_data = false);

// --- Reading: a scanner for the XML that save_model() writes, not a general XML parser. ---

using Attributes = std::map<std::string, std::string, std::less<>>;

struct XmlArray {
  Attributes attributes;
  std::string_view text;  // the values, pointing into the file's text
};

struct VtuFile {
  std::string type;  // VTKFile's type attribute
  Attributes piece;  // attributes of the (only) Piece
  int pieces = 0;
  std::map<std::string, XmlArray> arrays;  // keyed "Section/Name", e.g. "PointData/mass_kg"
};

// Untrusted text quoted in a message: short, and on one line.
std::string in_quotes(std::string_view text);
// The shortest text that reads back as `value`.
std::string str(double value);
// Field data arrays say how many tuples they hold.
int64_t tuple_count(const std::string& path, const VtuFile& f, const std::string& key);
// The values of array `key`, which must have type T, ASCII format and exactly `count` values.
// Defined for double, int64_t, int32_t and uint8_t.
template <class T>
std::vector<T> read_values(const std::string& path, const VtuFile& f, const std::string& key,
                           int64_t count, int components = 1);

// Walks the cells in file order, checking each one's VTK type, cell_kind and offset.
struct CellWalker {
  const std::string& path;
  const PieceArrays& piece;
  int64_t cell = -1;  // the cell next() returned last
  int64_t end = 0;    // where its nodes end in `connectivity`

  // The `size` nodes of the next cell, whose type must be `type` and whose cell_kind must lie in
  // [kind_min, kind_max]; `expected` names such a cell in the message otherwise.
  const int64_t* next(int64_t size, uint8_t type, uint8_t kind_min, uint8_t kind_max,
                      const std::string& expected);
};

uint32_t crc(uint32_t c, const void* data, size_t bytes);

// The model file's text, written to `out` and read from `text` (save_model() and load_model()
// around a file; a checkpoint holds a cut model's text in its own bytes); `path` names the
// source in messages.
void write_model(const Model& m, const std::string& path, std::ostream& out);
Model parse_model(const std::string& path, std::string_view text);

// --- The embedded surfaces (model_file_embedded.cpp). ---

// Names stored joined by '\n' as bytes (embedded_names, tree_names), split again.
std::vector<std::string> split_names(const std::vector<uint8_t>& bytes);

// Refuses (kInvalidInput) a name that would not read back as itself; (kInternal) arrays whose
// sizes disagree, which save_model() would read out of bounds.
void check_embedded_savable(const Model& m, const std::string& path);
// Appends every surface's vertices as points after the nodes and its triangles as cells.
void add_embedded(const Model& m, PieceArrays& piece);
// Whether any embedded surface has offsets (a version 4 file).
bool has_embedded_offsets(const Model& m);
// embed_corners and embed_weights over all points, embed_offset when any surface has offsets;
// nothing for a model without surfaces.
void write_embedded_point_data(std::ostream& out, const char* indent, const Model& m);
// The per-surface FieldData arrays; nothing for a model without surfaces.
void write_embedded_field_data(std::ostream& out, const char* indent, const Model& m);

// What a version 3 file's FieldData says of its surfaces.
struct EmbeddedLayout {
  std::vector<int32_t> vertex_count, face_count;
  int64_t vertices = 0, faces = 0;  // summed over the surfaces
};
// Reads and checks the FieldData arrays; m.embedded gets each surface's name, role, label and
// outside. Files before `version` 6 hold no roles: each surface gets the one the readers of its
// time saw (label 0 named "display_skin" or "wound": those; else the role its name suggests).
EmbeddedLayout read_embedded_fields(const std::string& path, const VtuFile& f, int32_t version,
                                    Model& m);
// The points from `n` on are the surfaces' vertices: checks their point data, reads
// embed_corners and embed_weights (checking the nodes' entries too), and with `offsets` (version
// 4) embed_offset; fills V, corners, weights, offsets.
void read_embedded_points(const std::string& path, const VtuFile& f, const PieceArrays& piece,
                          const EmbeddedLayout& layout, int32_t n, bool offsets, Model& m);
// The cells after the tetrahedra: each surface's triangles, on its own vertices.
void read_embedded_cells(const std::string& path, CellWalker& cells, const EmbeddedLayout& layout,
                         int32_t n, Model& m);
// model_fingerprint()'s share of the surfaces, continuing checksum `c`; with `roles` (files of
// version 6 on) their roles too.
uint32_t embedded_fingerprint(uint32_t c, const Model& m, bool roles);
// One surface's share (its name, label, role with `roles`, points, triangles, weights, offsets).
uint32_t surface_fingerprint(uint32_t c, const EmbeddedSurface& e, bool roles);
// model_fingerprint(), or the sum files before version 6 stored (without the roles).
uint32_t fingerprint(const Model& m, bool roles);

// --- The vessel trees (model_file_trees.cpp, format version 7). ---

// Refuses (kInvalidInput) a name that would not read back as itself; (kInternal) arrays whose
// sizes disagree.
void check_trees_savable(const Model& m, const std::string& path);
// The trees' FieldData arrays; nothing for a model without trees.
void write_tree_field_data(std::ostream& out, const char* indent, const Model& m);
// Reads and checks them into m.trees (after the nodes are read: corners are checked against them).
void read_trees(const std::string& path, const VtuFile& f, Model& m);
// model_fingerprint()'s share of the trees, continuing checksum `c`.
uint32_t trees_fingerprint(uint32_t c, const Model& m);

// --- A cut model's shares and materials (model_file_cut.cpp, format version 5). ---

// Whether a cut divided some of the model's tetrahedra (it has shares or materials).
bool is_cut(const Model& m);
// Refuses (kInternal) share and material arrays whose sizes disagree with the cells.
void check_cut_savable(const Model& m, const std::string& path);
// CellData `share` and `material` over all `cells` (1 and 15 for triangles); nothing for an
// uncut model.
void write_cut_cell_data(std::ostream& out, const char* indent, const Model& m, int64_t cells);
// Reads and checks them: the springs are the cells [first_spring, first_tet), the tetrahedra
// [first_tet, first_embedded); fills Springs::share, Tets::share and Tets::material.
void read_cut_cells(const std::string& path, const VtuFile& f, int64_t cells, int64_t first_spring,
                    int64_t first_tet, int64_t first_embedded, Model& m);
// model_fingerprint()'s share of the cut, continuing checksum `c` (unchanged when uncut).
uint32_t cut_fingerprint(uint32_t c, const Model& m);

}  // namespace lamina::io::detail
