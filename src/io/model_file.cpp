#include "lamina/io/model_file.h"

#include <zlib.h>

#include <Eigen/Geometry>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <ostream>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "lamina/core/atomic_file.h"
#include "lamina/core/error.h"
#include "model_file_internal.h"
#include "read_file.h"

namespace lamina::io {
namespace detail {

uint32_t crc(uint32_t c, const void* data, size_t bytes) {
  // zlib answers a null buffer (an empty vector's data()) with 0, the initial value: the sum so
  // far would be lost (a tree's seeds have no triangles).
  if (bytes == 0) return c;
  return static_cast<uint32_t>(crc32_z(c, static_cast<const Bytef*>(data), bytes));
}

std::string in_quotes(std::string_view text) {
  std::string q(text.substr(0, 40));
  for (char& c : q)
    if (static_cast<unsigned char>(c) < 0x20) c = '?';
  return "'" + q + (text.size() > 40 ? "...'" : "'");
}

namespace {

constexpr size_t kValuesPerLine = 12;  // a multiple of 3, so point rows stay whole

template <class T>
constexpr const char* vtk_type() {
  if constexpr (std::is_same_v<T, double>) return "Float64";
  if constexpr (std::is_same_v<T, int64_t>) return "Int64";
  if constexpr (std::is_same_v<T, int32_t>) return "Int32";
  if constexpr (std::is_same_v<T, uint8_t>) return "UInt8";
}

// std::to_chars without a format gives the shortest text that parses back to the same double,
// which is what makes the round trip bit-exact without a binary encoding.
template <class T>
void append_number(std::string& s, T value) {
  char buf[32];
  s.append(buf, std::to_chars(buf, buf + sizeof buf, value).ptr);
}

bool is_space(char c) {
  return c == ' ' || c == '\n' || c == '\r' || c == '\t';
}

// name="value" pairs of one start tag (our files need no XML escapes in attributes).
Attributes parse_attributes(std::string_view tag) {
  Attributes attributes;
  size_t at = 0;
  while ((at = tag.find('=', at)) != std::string_view::npos) {
    size_t key_begin = tag.rfind(' ', at);
    key_begin = key_begin == std::string_view::npos ? 0 : key_begin + 1;
    const size_t open = tag.find('"', at), close = tag.find('"', open + 1);
    if (open == std::string_view::npos || close == std::string_view::npos) break;
    attributes[std::string(tag.substr(key_begin, at - key_begin))] =
        std::string(tag.substr(open + 1, close - open - 1));
    at = close + 1;
  }
  return attributes;
}

int64_t parse_integer(const std::string& path, std::string_view text, const std::string& what) {
  int64_t value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size() || text.empty())
    throw invalid_input(path, what + " is " + in_quotes(text) + ", expected an integer");
  return value;
}

const XmlArray& find_array(const std::string& path, const VtuFile& f, const std::string& key) {
  const auto it = f.arrays.find(key);
  if (it == f.arrays.end()) throw invalid_input(path, "missing array " + in_quotes(key));
  return it->second;
}

}  // namespace

std::string str(double value) {
  std::string s;
  append_number(s, value);
  return s;
}

template <class T>
void write_array(std::ostream& out, const char* indent, const std::string& name,
                 const std::vector<T>& values, size_t components, bool field_data) {
  std::string s =
      std::string(indent) + "<DataArray type=\"" + vtk_type<T>() + "\" Name=\"" + name + "\"";
  if (components > 1) s += " NumberOfComponents=\"" + std::to_string(components) + "\"";
  if (field_data) s += " NumberOfTuples=\"" + std::to_string(values.size() / components) + "\"";
  s += " format=\"ascii\">\n";
  for (size_t k = 0; k < values.size(); ++k) {
    if (k % kValuesPerLine == 0) {
      if (s.size() > (size_t{1} << 20)) out << std::exchange(s, {});  // bound the buffer
      s.append(indent).append("  ");
    } else {
      s += ' ';
    }
    append_number(s, values[k]);
    if (k % kValuesPerLine == kValuesPerLine - 1 || k + 1 == values.size()) s += '\n';
  }
  out << s << indent << "</DataArray>\n";
}

int64_t tuple_count(const std::string& path, const VtuFile& f, const std::string& key) {
  const XmlArray& a = find_array(path, f, key);
  const auto it = a.attributes.find("NumberOfTuples");
  const int64_t count = parse_integer(path, it == a.attributes.end() ? "" : it->second,
                                      "NumberOfTuples of array " + in_quotes(key));
  if (count < 0 || count > std::numeric_limits<int32_t>::max())
    throw invalid_input(path,
                        "array " + in_quotes(key) + " claims " + std::to_string(count) + " tuples");
  return count;
}

template <class T>
std::vector<T> read_values(const std::string& path, const VtuFile& f, const std::string& key,
                           int64_t count, int components) {
  const XmlArray& a = find_array(path, f, key);
  const auto attribute = [&](const char* name, const char* fallback) {
    const auto it = a.attributes.find(name);
    return it == a.attributes.end() ? std::string(fallback) : it->second;
  };
  if (attribute("type", "") != vtk_type<T>())
    throw invalid_input(path, "array " + in_quotes(key) + " has type " +
                                  in_quotes(attribute("type", "")) + ", expected " + vtk_type<T>());
  if (attribute("format", "") != "ascii")
    throw invalid_input(path, "array " + in_quotes(key) + " has format " +
                                  in_quotes(attribute("format", "")) + ", only ascii is supported");
  if (attribute("NumberOfComponents", "1") != std::to_string(components))
    throw invalid_input(path, "array " + in_quotes(key) + " must have " +
                                  std::to_string(components) + " component(s)");
  std::vector<T> values;
  const char* p = a.text.data();
  const char* const end = p + a.text.size();
  while (true) {
    while (p < end && is_space(*p)) ++p;
    if (p == end) break;
    T value{};
    const auto [next, ec] = std::from_chars(p, end, value);
    if (ec != std::errc() || (next < end && !is_space(*next))) {
      const char* token_end = p;
      while (token_end < end && !is_space(*token_end)) ++token_end;
      throw invalid_input(path, "array " + in_quotes(key) + " value " +
                                    std::to_string(values.size()) + " is " +
                                    in_quotes({p, token_end}) + ", not a " + vtk_type<T>());
    }
    values.push_back(value);
    p = next;
  }
  if (static_cast<int64_t>(values.size()) != count)
    throw invalid_input(path, "array " + in_quotes(key) + " has " + std::to_string(values.size()) +
                                  " values, expected " + std::to_string(count) +
                                  " (truncated or corrupt file?)");
  return values;
}

// The four types the format uses, for model_file_embedded.cpp too.
template void write_array(std::ostream&, const char*, const std::string&,
                          const std::vector<double>&, size_t, bool);
template void write_array(std::ostream&, const char*, const std::string&,
                          const std::vector<int64_t>&, size_t, bool);
template void write_array(std::ostream&, const char*, const std::string&,
                          const std::vector<int32_t>&, size_t, bool);
template void write_array(std::ostream&, const char*, const std::string&,
                          const std::vector<uint8_t>&, size_t, bool);
template std::vector<double> read_values(const std::string&, const VtuFile&, const std::string&,
                                         int64_t, int);
template std::vector<int64_t> read_values(const std::string&, const VtuFile&, const std::string&,
                                          int64_t, int);
template std::vector<int32_t> read_values(const std::string&, const VtuFile&, const std::string&,
                                          int64_t, int);
template std::vector<uint8_t> read_values(const std::string&, const VtuFile&, const std::string&,
                                          int64_t, int);

void PieceArrays::add_cell(uint8_t type, uint8_t kind, int32_t layer,
                           std::initializer_list<int64_t> nodes, double rest, double k) {
  connectivity.insert(connectivity.end(), nodes);
  offsets.push_back(static_cast<int64_t>(connectivity.size()));
  types.push_back(type);
  cell_kind.push_back(kind);
  cell_layer.push_back(layer);
  rest_length.push_back(rest);
  stiffness.push_back(k);
}

const int64_t* CellWalker::next(int64_t size, uint8_t type, uint8_t kind_min, uint8_t kind_max,
                                const std::string& expected) {
  ++cell;
  const int t = piece.types[cell], kind = piece.cell_kind[cell];
  if (t != type || kind < kind_min || kind > kind_max)
    throw invalid_input(path, "cell " + std::to_string(cell) + ": VTK cell type " +
                                  std::to_string(t) + " with cell_kind " + std::to_string(kind) +
                                  " does not agree with the expected " + expected);
  if (piece.offsets[cell] != end + size)
    throw invalid_input(path, "cell " + std::to_string(cell) + ": offset " +
                                  std::to_string(piece.offsets[cell]) + ", expected " +
                                  std::to_string(end + size));
  end += size;
  return piece.connectivity.data() + (end - size);
}

}  // namespace detail

namespace {

using namespace detail;

// Version 4 added the offsets of embedded vertices far outside the tetrahedra (embed_offset); a
// model whose surfaces have none is still written as version 3.
// Version 3 added the embedded surfaces (their vertices as points after the nodes, their
// triangles as cells after the tetrahedra). A model without any is still written as version 2,
// the oldest layout that holds it, so that builds from before version 3 read it too.
// Version 2 added interior nodes (layer -1, after the layers) and tetrahedra (VTK_TETRA cells
// after the springs, counted by tet_count). Version 1 files (layers joined by links) still load.
// Version 5 added the shares and materials of a cut model's springs and tetrahedra (CellData
// share and material); an uncut model is still written as the oldest version that holds it.
// Version 6 added each embedded surface's role (FieldData embedded_role): every model with
// embedded surfaces is written as version 6; in older files the reader gives each the role the
// older readers saw in its name and label (read_embedded_fields).
// Version 7 added the vessel trees (FieldData tree_*, seed_*, branch_*; issue 63): a model with
// trees is written as 7, one without as before.
constexpr int32_t kFormatVersion = 7;
constexpr int32_t kFormatVersionEmbedded = 6;
constexpr int32_t kFormatVersionCut = 5;
constexpr int32_t kFormatVersionWithoutEmbedded = 2;

// Only what would make save_model() itself read out of bounds; load_model() checks the rest.
void check_savable(const Model& m, const std::string& path) {
  const size_t n = static_cast<size_t>(m.node_count());
  const Springs& s = m.springs;
  bool ok = m.mass_kg.size() == n && m.layer_of.size() == n && m.fixed.size() == n &&
            s.j.size() == s.size() && s.rest_length_mm.size() == s.size() &&
            s.stiffness_n_per_m.size() == s.size() && s.kind.size() == s.size() &&
            m.tets.region.size() == static_cast<size_t>(m.tets.size());
  for (size_t k = 0; ok && k < s.size(); ++k) ok = s.i[k] >= 0 && static_cast<size_t>(s.i[k]) < n;
  for (size_t k = 0; ok && k < m.layer_of.size(); ++k) ok = m.layer_of[k] >= kInteriorNode;
  ok = ok && (m.tets.size() == 0 ||
              (m.tets.T.minCoeff() >= 0 && m.tets.T.maxCoeff() < static_cast<int>(n)));
  if (!ok)
    throw Error(ErrorKind::kInternal,
                path + ": cannot save: the model's arrays disagree in size or index range");
  check_embedded_savable(m, path);
  check_trees_savable(m, path);
  check_cut_savable(m, path);
}

// --- Reading: a scanner for the XML that save_model() writes, not a general XML parser. ---

// Finds the DataArrays of `s` (the text of `path`); the result points into `s`.
VtuFile scan_vtu(const std::string& path, std::string_view s) {
  VtuFile f;
  std::string section;
  bool opened = false, closed = false;
  size_t pos = 0;
  while ((pos = s.find('<', pos)) != std::string_view::npos) {
    const bool comment = s.substr(pos, 4) == "<!--";
    const size_t end = comment ? s.find("-->", pos) : s.find('>', pos);
    if (end == std::string_view::npos)
      throw invalid_input(path, "truncated file (a tag is cut off)");
    std::string_view tag = s.substr(pos + 1, end - pos - 1);
    pos = end + 1;
    if (comment || tag.starts_with('?')) continue;
    if (tag.starts_with('/')) {
      tag.remove_prefix(1);
      if (tag == section) section.clear();
      closed = closed || tag == "VTKFile";
      continue;
    }
    const bool empty_element = tag.ends_with('/');
    if (empty_element) tag.remove_suffix(1);
    const std::string name(tag.substr(0, std::min(tag.size(), tag.find_first_of(" \t\r\n"))));
    auto attributes = parse_attributes(tag.substr(name.size()));
    if (name == "VTKFile") {
      opened = true;
      f.type = attributes["type"];
    } else if (name == "Piece") {
      ++f.pieces;
      f.piece = std::move(attributes);
    } else if (name == "FieldData" || name == "PointData" || name == "CellData" ||
               name == "Points" || name == "Cells") {
      if (!empty_element) section = name;
    } else if (name == "DataArray") {
      XmlArray a{std::move(attributes), {}};
      const std::string key = section + "/" + a.attributes["Name"];
      if (!empty_element) {
        const size_t close = s.find("</DataArray>", pos);
        if (close == std::string_view::npos)
          throw invalid_input(
              path, "truncated file (array " + in_quotes(a.attributes["Name"]) + " is cut off)");
        a.text = s.substr(pos, close - pos);
        pos = close;
      }
      if (!f.arrays.emplace(key, std::move(a)).second)
        throw invalid_input(path, "array " + in_quotes(key) + " appears twice");
    }
  }
  if (!opened) throw invalid_input(path, "not a VTK XML file (no <VTKFile> element)");
  if (!closed) throw invalid_input(path, "truncated file (no closing </VTKFile>)");
  return f;
}

bool positive_finite(double x) {
  return std::isfinite(x) && x > 0.0;
}

}  // namespace

void detail::write_model(const Model& m, const std::string& path, std::ostream& out) {
  check_savable(m, path);
  const int32_t n = m.node_count();
  PieceArrays piece;
  piece.points.resize(3 * static_cast<size_t>(n));
  for (int32_t v = 0; v < n; ++v)
    for (int c = 0; c < 3; ++c) piece.points[3 * static_cast<size_t>(v) + c] = m.X(v, c);
  piece.point_layer = m.layer_of;
  piece.mass_kg = m.mass_kg;
  piece.fixed = m.fixed;

  std::vector<int32_t> first_node, node_count, face_count;
  for (const ModelLayer& layer : m.layers) {
    first_node.push_back(layer.first_node);
    node_count.push_back(layer.node_count);
    face_count.push_back(static_cast<int32_t>(layer.F.rows()));
  }

  // Cells: every layer's triangles, then every spring as a line, then the tetrahedra; the
  // CellData arrays run alongside.
  for (int32_t l = 0; l < m.layer_count(); ++l) {
    const Eigen::MatrixX3i& F = m.layers[l].F;
    for (Eigen::Index t = 0; t < F.rows(); ++t)
      piece.add_cell(kVtkTriangle, kCellKindTriangle, l, {F(t, 0), F(t, 1), F(t, 2)});
  }
  const Springs& s = m.springs;
  for (size_t k = 0; k < s.size(); ++k)
    piece.add_cell(kVtkLine, static_cast<uint8_t>(1 + static_cast<int>(s.kind[k])),
                   m.layer_of[s.i[k]], {s.i[k], s.j[k]}, s.rest_length_mm[k],
                   s.stiffness_n_per_m[k]);
  // Their cell `layer` is their region (the shell just inside that layer).
  const Eigen::MatrixX4i& T = m.tets.T;
  for (Eigen::Index t = 0; t < T.rows(); ++t)
    piece.add_cell(kVtkTetra, kCellKindTetra, m.tets.region[static_cast<size_t>(t)],
                   {T(t, 0), T(t, 1), T(t, 2), T(t, 3)});
  // Last, after the nodes and after the tetrahedra, so that everything before them is laid out
  // as in version 2.
  add_embedded(m, piece);
  const std::vector<uint8_t> source(m.source.begin(), m.source.end());
  const int32_t version = !m.trees.empty()      ? kFormatVersion
                          : !m.embedded.empty() ? kFormatVersionEmbedded
                          : is_cut(m)           ? kFormatVersionCut
                                                : kFormatVersionWithoutEmbedded;

  {
    const char* const field = "      ";
    const char* const indent = "        ";
    out << "<?xml version=\"1.0\"?>\n"
           "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
           "header_type=\"UInt64\">\n"
           "  <UnstructuredGrid>\n"
           "    <FieldData>\n";
    write_array(out, field, "lamina_format_version", std::vector<int32_t>{version}, 1, true);
    write_array(out, field, "ring_locality", std::vector<int32_t>{m.rings.locality}, 1, true);
    write_array(out, field, "density_kg_per_mm3", std::vector<double>{m.density_kg_per_mm3}, 1,
                true);
    write_array(out, field, "layer_first_node", first_node, 1, true);
    write_array(out, field, "layer_node_count", node_count, 1, true);
    write_array(out, field, "layer_face_count", face_count, 1, true);
    write_array(out, field, "tet_count", std::vector<int64_t>{m.tets.size()}, 1, true);
    write_embedded_field_data(out, field, m);
    write_tree_field_data(out, field, m);
    write_array(out, field, "source", source, 1, true);
    write_array(out, field, "content_crc32",
                std::vector<int64_t>{static_cast<int64_t>(model_fingerprint(m))}, 1, true);
    out << "    </FieldData>\n"
        << "    <Piece NumberOfPoints=\"" << piece.points.size() / 3 << "\" NumberOfCells=\""
        << piece.types.size() << "\">\n"
        << "      <PointData>\n";
    write_array(out, indent, "layer", piece.point_layer);
    write_array(out, indent, "mass_kg", piece.mass_kg);
    write_array(out, indent, "fixed", piece.fixed);
    write_embedded_point_data(out, indent, m);
    out << "      </PointData>\n      <CellData>\n";
    write_array(out, indent, "cell_kind", piece.cell_kind);
    write_array(out, indent, "layer", piece.cell_layer);
    write_array(out, indent, "rest_length_mm", piece.rest_length);
    write_array(out, indent, "stiffness_n_per_m", piece.stiffness);
    write_cut_cell_data(out, indent, m, static_cast<int64_t>(piece.types.size()));
    out << "      </CellData>\n      <Points>\n";
    write_array(out, indent, "Points", piece.points, 3);
    out << "      </Points>\n      <Cells>\n";
    write_array(out, indent, "connectivity", piece.connectivity);
    write_array(out, indent, "offsets", piece.offsets);
    write_array(out, indent, "types", piece.types);
    out << "      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n";
  }
}

void save_model(const Model& m, const std::string& path) {
  check_savable(m, path);  // before the file is opened: nothing is written for a bad model
  write_file_atomically(path, [&](std::ostream& out) { detail::write_model(m, path, out); });
}

Model load_model(const std::string& path) {
  return detail::parse_model(path, detail::read_whole_file(path));
}

Model detail::parse_model(const std::string& path, std::string_view text) {
  const VtuFile f = scan_vtu(path, text);
  const auto bad = [&](const std::string& problem) { return invalid_input(path, problem); };

  // The version decides how to read everything else, so it is checked first.
  if (!f.arrays.contains("FieldData/lamina_format_version"))
    throw bad("not a Lamina model (no lamina_format_version field)");
  const int32_t version = read_values<int32_t>(path, f, "FieldData/lamina_format_version", 1)[0];
  if (version < 1 || version > kFormatVersion)
    throw bad("unsupported Lamina model format version " + std::to_string(version) +
              " (this build reads versions 1 to " + std::to_string(kFormatVersion) + ")");
  if (f.type != "UnstructuredGrid" || f.pieces != 1)
    throw bad("expected a VTK UnstructuredGrid with exactly one Piece");
  const auto piece_count = [&](const char* name, int64_t max) {
    const auto it = f.piece.find(name);
    const int64_t count = parse_integer(path, it == f.piece.end() ? "" : it->second,
                                        std::string("Piece attribute ") + name);
    if (count < 0 || count > max) throw bad(std::string(name) + " is out of range");
    return count;
  };
  const int64_t points_in_file = piece_count("NumberOfPoints", std::numeric_limits<int32_t>::max());
  const int64_t cells = piece_count("NumberOfCells", int64_t{1} << 60);

  Model m;
  // Version 3: the embedded surfaces' vertices are the last points, their triangles the last
  // cells; everything before them is laid out as in version 2.
  // A cut model (version 5) without embedded surfaces has none of their arrays.
  const bool has_embedded =
      version >= 3 && (version < 5 || f.arrays.contains("FieldData/embedded_vertex_count"));
  const EmbeddedLayout embedded =
      has_embedded ? read_embedded_fields(path, f, version, m) : EmbeddedLayout{};
  if (embedded.vertices > points_in_file)
    throw bad("the embedded surfaces hold " + std::to_string(embedded.vertices) +
              " vertices but the file has only " + std::to_string(points_in_file) + " points");
  const int64_t n = points_in_file - embedded.vertices;  // the model's nodes
  m.rings.locality = read_values<int32_t>(path, f, "FieldData/ring_locality", 1)[0];
  if (m.rings.locality < 0) throw bad("ring_locality must be >= 0");
  m.density_kg_per_mm3 = read_values<double>(path, f, "FieldData/density_kg_per_mm3", 1)[0];
  if (!positive_finite(m.density_kg_per_mm3))
    throw bad("density_kg_per_mm3 is " + str(m.density_kg_per_mm3) + ", must be finite and > 0");
  const auto source =
      read_values<uint8_t>(path, f, "FieldData/source", tuple_count(path, f, "FieldData/source"));
  m.source.assign(source.begin(), source.end());

  // Layer k owns the nodes [first_node[k], first_node[k] + node_count[k]); together the layers
  // must tile [0, n) in order.
  const int64_t layer_count = tuple_count(path, f, "FieldData/layer_first_node");
  const auto first = read_values<int32_t>(path, f, "FieldData/layer_first_node", layer_count);
  const auto count = read_values<int32_t>(path, f, "FieldData/layer_node_count", layer_count);
  const auto faces = read_values<int32_t>(path, f, "FieldData/layer_face_count", layer_count);
  int64_t next_node = 0, triangles = 0;
  m.layers.resize(layer_count);
  for (int64_t l = 0; l < layer_count; ++l) {
    if (first[l] != next_node || count[l] < 0 || faces[l] < 0)
      throw bad("layer " + std::to_string(l) + " starts at node " + std::to_string(first[l]) +
                " with " + std::to_string(count[l]) + " nodes and " + std::to_string(faces[l]) +
                " faces; expected it to start at node " + std::to_string(next_node));
    m.layers[l].first_node = first[l];
    m.layers[l].node_count = count[l];
    next_node += count[l];
    triangles += faces[l];
  }
  // Version 2: nodes after the layers are interior nodes of the tetrahedra.
  if (next_node > n || (version == 1 && next_node != n))
    throw bad("the layers hold " + std::to_string(next_node) + " nodes but the file has " +
              std::to_string(n) + " points");
  const int64_t tet_count =
      version == 1 ? 0 : read_values<int64_t>(path, f, "FieldData/tet_count", 1)[0];
  if (tet_count < 0 || triangles + tet_count + embedded.faces > cells)
    throw bad("layer_face_count, tet_count and embedded_face_count add up to " +
              std::to_string(triangles + tet_count + embedded.faces) +
              " cells but the file has only " + std::to_string(cells));
  if (next_node != n && tet_count == 0)
    throw bad("the file has " + std::to_string(n - next_node) +
              " node(s) on no layer but no tetrahedra to hold them");
  // A surface is carried by the tetrahedra's corners: without them it has nothing to follow.
  if (!m.embedded.empty() && tet_count == 0)
    throw bad("embedded surfaces need tetrahedra, and the model has none");

  // Every point's values; the nodes' are checked here, the embedded vertices' further down.
  PieceArrays piece;
  piece.points = read_values<double>(path, f, "Points/Points", 3 * points_in_file, 3);
  piece.point_layer = read_values<int32_t>(path, f, "PointData/layer", points_in_file);
  piece.mass_kg = read_values<double>(path, f, "PointData/mass_kg", points_in_file);
  piece.fixed = read_values<uint8_t>(path, f, "PointData/fixed", points_in_file);
  const std::vector<double>& points = piece.points;
  m.layer_of.assign(piece.point_layer.begin(), piece.point_layer.begin() + n);
  m.mass_kg.assign(piece.mass_kg.begin(), piece.mass_kg.begin() + n);
  m.fixed.assign(piece.fixed.begin(), piece.fixed.begin() + n);
  m.X.resize(n, 3);
  for (int32_t v = 0, l = 0; v < n; ++v) {
    while (l < layer_count && v >= first[l] + count[l]) ++l;
    const int32_t expected = l < layer_count ? l : kInteriorNode;
    const std::string node = "node " + std::to_string(v) + ": ";
    for (int c = 0; c < 3; ++c) m.X(v, c) = points[3 * static_cast<size_t>(v) + c];
    if (!m.X.row(v).allFinite()) throw bad(node + "position is not finite");
    if (m.layer_of[v] != expected)
      throw bad(node + "layer is " + std::to_string(m.layer_of[v]) +
                " but the layer ranges put it in layer " + std::to_string(expected));
    if (!positive_finite(m.mass_kg[v]))
      throw bad(node + "mass_kg is " + str(m.mass_kg[v]) + ", must be finite and > 0");
    if (m.fixed[v] > 1) throw bad(node + "fixed must be 0 or 1");
  }

  // Version 4 has offsets; version 5 has them when some vertex needs one.
  const bool offsets =
      version == 4 || (version >= 5 && f.arrays.contains("PointData/embed_offset"));
  if (has_embedded)
    read_embedded_points(path, f, piece, embedded, static_cast<int32_t>(n), offsets, m);

  const int64_t spring_count = cells - triangles - tet_count - embedded.faces;
  piece.connectivity =
      read_values<int64_t>(path, f, "Cells/connectivity",
                           3 * triangles + 2 * spring_count + 4 * tet_count + 3 * embedded.faces);
  piece.offsets = read_values<int64_t>(path, f, "Cells/offsets", cells);
  piece.types = read_values<uint8_t>(path, f, "Cells/types", cells);
  piece.cell_kind = read_values<uint8_t>(path, f, "CellData/cell_kind", cells);
  piece.cell_layer = read_values<int32_t>(path, f, "CellData/layer", cells);
  piece.rest_length = read_values<double>(path, f, "CellData/rest_length_mm", cells);
  piece.stiffness = read_values<double>(path, f, "CellData/stiffness_n_per_m", cells);
  const std::vector<int32_t>& cell_layer = piece.cell_layer;
  const std::vector<double>&rest = piece.rest_length, &stiffness = piece.stiffness;

  CellWalker cells_in_order{path, piece};
  const int64_t& cell = cells_in_order.cell;
  for (int32_t l = 0; l < layer_count; ++l) {
    ModelLayer& layer = m.layers[l];
    layer.F.resize(faces[l], 3);
    const std::string expected = "triangle of layer " + std::to_string(l) + " (type 5, kind 0)";
    for (int32_t t = 0; t < faces[l]; ++t) {
      const int64_t* corner =
          cells_in_order.next(3, kVtkTriangle, kCellKindTriangle, kCellKindTriangle, expected);
      for (int c = 0; c < 3; ++c) {
        if (corner[c] < layer.first_node || corner[c] >= layer.first_node + layer.node_count)
          throw bad("triangle " + std::to_string(t) + " of layer " + std::to_string(l) +
                    " uses node " + std::to_string(corner[c]) + ", outside the layer's nodes [" +
                    std::to_string(layer.first_node) + ", " +
                    std::to_string(layer.first_node + layer.node_count) + ")");
        layer.F(t, c) = static_cast<int>(corner[c]);
      }
      if (cell_layer[cell] != l)
        throw bad("cell " + std::to_string(cell) + ": layer is " +
                  std::to_string(cell_layer[cell]) + ", expected " + std::to_string(l));
    }
  }

  Springs& s = m.springs;
  for (int64_t k = 0; k < spring_count; ++k) {
    const int64_t* node = cells_in_order.next(2, kVtkLine, 1, 3, "spring (type 3, kind 1, 2 or 3)");
    const std::string spring = "spring " + std::to_string(k) + ": ";
    if (node[0] < 0 || node[0] >= node[1] || node[1] >= n)
      throw bad(spring + "joins nodes " + std::to_string(node[0]) + " and " +
                std::to_string(node[1]) + "; expected 0 <= i < j < " + std::to_string(n));
    const auto i = static_cast<int32_t>(node[0]), j = static_cast<int32_t>(node[1]);
    const auto kind = static_cast<SpringKind>(piece.cell_kind[cell] - 1);
    const bool same_layer = m.layer_of[i] == m.layer_of[j] && m.layer_of[i] != kInteriorNode;
    if ((kind == SpringKind::kIntraLayer && !same_layer) ||
        (kind == SpringKind::kInterLayer &&
         (m.layer_of[i] == m.layer_of[j] || m.layer_of[i] == kInteriorNode ||
          m.layer_of[j] == kInteriorNode)) ||
        (kind == SpringKind::kVolume && tet_count == 0))
      throw bad(spring +
                (kind == SpringKind::kIntraLayer   ? "an intra-layer spring"
                 : kind == SpringKind::kInterLayer ? "an inter-layer spring"
                                                   : "a tetrahedron-edge spring") +
                " joins nodes of layers " + std::to_string(m.layer_of[i]) + " and " +
                std::to_string(m.layer_of[j]));
    if (cell_layer[cell] != m.layer_of[i])
      throw bad(spring + "layer is " + std::to_string(cell_layer[cell]) + ", but node " +
                std::to_string(i) + " is in layer " + std::to_string(m.layer_of[i]));
    if (!positive_finite(rest[cell]))
      throw bad(spring + "rest_length_mm is " + str(rest[cell]) + ", must be finite and > 0");
    if (!positive_finite(stiffness[cell]))
      throw bad(spring + "stiffness_n_per_m is " + str(stiffness[cell]) +
                ", must be finite and > 0");
    s.i.push_back(i);
    s.j.push_back(j);
    s.rest_length_mm.push_back(rest[cell]);
    s.stiffness_n_per_m.push_back(stiffness[cell]);
    s.kind.push_back(kind);
  }

  // Tetrahedra: four distinct nodes, positive volume at rest, a region that is a layer.
  m.tets.T.resize(tet_count, 4);
  m.tets.region.resize(static_cast<size_t>(tet_count));
  for (int64_t t = 0; t < tet_count; ++t) {
    const int64_t* node = cells_in_order.next(4, kVtkTetra, kCellKindTetra, kCellKindTetra,
                                              "tetrahedron (type 10, kind 4)");
    const std::string tet = "tetrahedron " + std::to_string(t) + ": ";
    for (int c = 0; c < 4; ++c) {
      if (node[c] < 0 || node[c] >= n)
        throw bad(tet + "node " + std::to_string(node[c]) + " is not in the model");
      m.tets.T(t, c) = static_cast<int>(node[c]);
    }
    const Eigen::Vector3d p0 = m.X.row(m.tets.T(t, 0)), p1 = m.X.row(m.tets.T(t, 1)),
                          p2 = m.X.row(m.tets.T(t, 2)), p3 = m.X.row(m.tets.T(t, 3));
    if (!((p1 - p0).cross(p2 - p0).dot(p3 - p0) > 0.0))
      throw bad(tet + "is flat or inverted at rest (its volume must be positive)");
    if (cell_layer[cell] < 0 || cell_layer[cell] >= layer_count)
      throw bad(tet + "region " + std::to_string(cell_layer[cell]) + " is not a layer");
    m.tets.region[static_cast<size_t>(t)] = cell_layer[cell];
  }
  if (has_embedded) read_embedded_cells(path, cells_in_order, embedded, static_cast<int32_t>(n), m);
  // A cut model: version 5 always; from version 6 (roles) a model with embedded surfaces is
  // written as 6 cut or not, so the shares are there when it is cut.
  if (version == 5 || (version >= 6 && f.arrays.contains("CellData/share")))
    read_cut_cells(path, f, cells, triangles, triangles + spring_count,
                   triangles + spring_count + tet_count, m);
  if (version >= 7 && f.arrays.contains("FieldData/tree_kind")) read_trees(path, f, m);
  // Every value above passed its own check; the checksum catches one changed to another valid
  // value (an edited position or stiffness). Files written before it existed have none.
  if (f.arrays.contains("FieldData/content_crc32")) {
    const int64_t stored = read_values<int64_t>(path, f, "FieldData/content_crc32", 1)[0];
    // Files before version 6 were summed without the roles.
    if (stored != static_cast<int64_t>(detail::fingerprint(m, /*roles=*/version >= 6)))
      throw bad(
          "contents do not match their checksum (content_crc32): the file was edited or "
          "damaged; rebuild it with lamina build");
  }
  return m;
}

uint32_t model_fingerprint(const Model& m) {
  return detail::fingerprint(m, /*roles=*/true);
}

}  // namespace lamina::io

namespace lamina::io::detail {

uint32_t fingerprint(const Model& m, bool roles) {
  uint32_t c = crc(0, m.X.data(), static_cast<size_t>(m.X.size()) * sizeof(double));
  c = crc(c, m.mass_kg.data(), m.mass_kg.size() * sizeof(double));
  c = crc(c, m.fixed.data(), m.fixed.size());
  c = crc(c, m.layer_of.data(), m.layer_of.size() * sizeof(int32_t));
  for (const ModelLayer& l : m.layers)
    c = crc(c, l.F.data(), static_cast<size_t>(l.F.size()) * sizeof(int));
  const Springs& s = m.springs;
  c = crc(c, s.i.data(), s.i.size() * sizeof(int32_t));
  c = crc(c, s.j.data(), s.j.size() * sizeof(int32_t));
  c = crc(c, s.rest_length_mm.data(), s.rest_length_mm.size() * sizeof(double));
  c = crc(c, s.stiffness_n_per_m.data(), s.stiffness_n_per_m.size() * sizeof(double));
  // Models without tetrahedra keep the checksum version 1 gave them.
  if (m.tets.size() > 0) {
    c = crc(c, m.tets.T.data(), static_cast<size_t>(m.tets.T.size()) * sizeof(int));
    c = crc(c, m.tets.region.data(), m.tets.region.size() * sizeof(int32_t));
  }
  // Models without embedded surfaces keep the checksum version 2 gave them (checkpoints name
  // their model by it).
  if (!m.embedded.empty()) c = embedded_fingerprint(c, m, roles);
  c = cut_fingerprint(c, m);
  // Models without trees keep the checksum version 6 gave them.
  return m.trees.empty() ? c : trees_fingerprint(c, m);
}

}  // namespace lamina::io::detail
