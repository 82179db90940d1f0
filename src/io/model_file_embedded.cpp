// The embedded surfaces' part of the model file (format version 3, docs/model_format.md): each
// surface's vertices are points after the model's nodes, with their tetrahedron's four corners
// and barycentric weights as point data; its triangles are cells after the tetrahedra. The
// per-surface counts, labels and names are field data.

#include <cmath>
#include <cstdint>
#include <limits>
#include <ostream>
#include <string>
#include <vector>

#include "lamina/core/error.h"
#include "lamina/geometry/structure_names.h"
#include "lamina/model/cut_tetrahedra.h"
#include "lamina/model/embed_surface.h"
#include "lamina/model/structure_colors.h"
#include "model_file_internal.h"

namespace lamina::io::detail {
namespace {

// The weights of a vertex sum to 1 up to the rounding of embed_surface's arithmetic; more than
// this and it would not follow its tetrahedron's affine motion.
constexpr double kWeightSumTolerance = 1e-9;

// "embedded surface 1 ('tumour')": the index, and the name as far as it is safe to print.
std::string surface_named(const Model& m, size_t s) {
  return "embedded surface " + std::to_string(s) + " (" + in_quotes(m.embedded[s].name) + ")";
}

}  // namespace

std::vector<std::string> split_names(const std::vector<uint8_t>& bytes) {
  std::vector<std::string> names;
  if (!bytes.empty()) names.emplace_back();
  for (const uint8_t b : bytes) {
    if (b == '\n')
      names.emplace_back();
    else
      names.back() += static_cast<char>(b);
  }
  return names;
}

void check_embedded_savable(const Model& m, const std::string& path) {
  int64_t points = m.node_count();
  for (size_t s = 0; s < m.embedded.size(); ++s) {
    const EmbeddedSurface& e = m.embedded[s];
    // The names are stored joined by '\n': an empty one, or one holding a '\n', would read back
    // as another list of names.
    if (e.name.empty() || e.name.find('\n') != std::string::npos)
      throw invalid_input(path, "cannot save: embedded surface " + std::to_string(s) +
                                    " has the name " + in_quotes(e.name) +
                                    "; a name must be non-empty and on one line");
    if (e.corners.rows() != e.V.rows() || e.weights.rows() != e.V.rows() ||
        (e.offsets.rows() != 0 && e.offsets.rows() != e.V.rows()))
      throw Error(ErrorKind::kInternal, path + ": cannot save: " + surface_named(m, s) +
                                            " has arrays that disagree in size");
    points += e.V.rows();
  }
  if (points > std::numeric_limits<int32_t>::max())
    throw invalid_input(path, "cannot save: " + std::to_string(points) +
                                  " nodes and embedded vertices are more points than a model "
                                  "file holds (2^31 - 1)");
}

void add_embedded(const Model& m, PieceArrays& piece) {
  int64_t first = m.node_count();  // the surface's vertex 0, as a point of the file
  for (size_t s = 0; s < m.embedded.size(); ++s) {
    const EmbeddedSurface& e = m.embedded[s];
    for (Eigen::Index v = 0; v < e.V.rows(); ++v) {
      piece.points.insert(piece.points.end(), {e.V(v, 0), e.V(v, 1), e.V(v, 2)});
      piece.point_layer.push_back(kEmbeddedVertexLayer);
      piece.mass_kg.push_back(0.0);  // the nodes carry all the mass
      piece.fixed.push_back(0);
    }
    // Global point indices, so that ParaView draws each triangle where its vertices are.
    for (Eigen::Index t = 0; t < e.F.rows(); ++t)
      piece.add_cell(kVtkTriangle, kCellKindEmbeddedTriangle, static_cast<int32_t>(s),
                     {first + e.F(t, 0), first + e.F(t, 1), first + e.F(t, 2)});
    first += e.V.rows();
  }
}

bool has_embedded_offsets(const Model& m) {
  for (const EmbeddedSurface& e : m.embedded)
    if (e.offsets.rows() > 0) return true;
  return false;
}

void write_embedded_point_data(std::ostream& out, const char* indent, const Model& m) {
  if (m.embedded.empty()) return;
  // A node is no embedded vertex: corners -1, weights 0.
  std::vector<int64_t> corners(4 * static_cast<size_t>(m.node_count()), -1);
  std::vector<double> weights(corners.size(), 0.0);
  for (const EmbeddedSurface& e : m.embedded)
    for (Eigen::Index v = 0; v < e.V.rows(); ++v)
      for (int c = 0; c < 4; ++c) {
        corners.push_back(e.corners(v, c));
        weights.push_back(e.weights(v, c));
      }
  write_array(out, indent, "embed_corners", corners, 4);
  write_array(out, indent, "embed_weights", weights, 4);
  // For ParaView, not read back: the organ's colour on the nodes and each surface's on its
  // vertices (model::structure_colors), so that colouring by "color" with Map Scalars off shows
  // the anatomy as the viewer does.
  std::vector<uint8_t> color;
  color.reserve(3 * (static_cast<size_t>(m.node_count()) + weights.size() / 4));
  for (int32_t v = 0; v < m.node_count(); ++v)
    color.insert(color.end(), model::kOrganColor.begin(), model::kOrganColor.end());
  const std::vector<model::Rgb8> colors = model::structure_colors(m);
  for (size_t s = 0; s < m.embedded.size(); ++s)
    for (Eigen::Index v = 0; v < m.embedded[s].V.rows(); ++v)
      color.insert(color.end(), colors[s].begin(), colors[s].end());
  write_array(out, indent, "color", color, 3);
  if (!has_embedded_offsets(m)) return;
  std::vector<double> offsets(3 * static_cast<size_t>(m.node_count()), 0.0);
  for (const EmbeddedSurface& e : m.embedded)
    for (Eigen::Index v = 0; v < e.V.rows(); ++v)
      for (int c = 0; c < 3; ++c) offsets.push_back(e.offsets.rows() > 0 ? e.offsets(v, c) : 0.0);
  write_array(out, indent, "embed_offset", offsets, 3);
}

void write_embedded_field_data(std::ostream& out, const char* indent, const Model& m) {
  if (m.embedded.empty()) return;
  std::vector<int32_t> vertex_count, face_count, label, outside, role;
  std::vector<uint8_t> names;  // joined by '\n', as bytes: no XML escaping needed
  for (const EmbeddedSurface& e : m.embedded) {
    vertex_count.push_back(static_cast<int32_t>(e.V.rows()));
    face_count.push_back(static_cast<int32_t>(e.F.rows()));
    label.push_back(e.label);
    role.push_back(static_cast<int32_t>(e.role));
    outside.push_back(e.outside);
    if (!names.empty()) names.push_back('\n');
    names.insert(names.end(), e.name.begin(), e.name.end());
  }
  write_array(out, indent, "embedded_vertex_count", vertex_count, 1, true);
  write_array(out, indent, "embedded_face_count", face_count, 1, true);
  write_array(out, indent, "embedded_label", label, 1, true);
  write_array(out, indent, "embedded_role", role, 1, true);
  write_array(out, indent, "embedded_outside", outside, 1, true);
  write_array(out, indent, "embedded_names", names, 1, true);
}

EmbeddedLayout read_embedded_fields(const std::string& path, const VtuFile& f, int32_t version,
                                    Model& m) {
  const auto bad = [&](const std::string& problem) { return invalid_input(path, problem); };
  const int64_t count = tuple_count(path, f, "FieldData/embedded_vertex_count");
  EmbeddedLayout layout;
  layout.vertex_count = read_values<int32_t>(path, f, "FieldData/embedded_vertex_count", count);
  layout.face_count = read_values<int32_t>(path, f, "FieldData/embedded_face_count", count);
  const auto label = read_values<int32_t>(path, f, "FieldData/embedded_label", count);
  const auto role = version >= 6 ? read_values<int32_t>(path, f, "FieldData/embedded_role", count)
                                 : std::vector<int32_t>{};
  const auto outside = read_values<int32_t>(path, f, "FieldData/embedded_outside", count);
  const auto bytes = read_values<uint8_t>(path, f, "FieldData/embedded_names",
                                          tuple_count(path, f, "FieldData/embedded_names"));
  const std::vector<std::string> names = split_names(bytes);
  if (static_cast<int64_t>(names.size()) != count)
    throw bad("embedded_names holds " + std::to_string(names.size()) + " name(s) for " +
              std::to_string(count) + " embedded surface(s)");
  m.embedded.resize(static_cast<size_t>(count));
  for (size_t s = 0; s < m.embedded.size(); ++s) {
    if (names[s].empty()) throw bad("embedded surface " + std::to_string(s) + " has no name");
    EmbeddedSurface& e = m.embedded[s];
    e.name = names[s];
    e.label = label[s];
    if (version >= 6) {
      if (role[s] < 0 || role[s] > static_cast<int32_t>(SurfaceRole::kWound))
        throw bad(surface_named(m, s) + " has role " + std::to_string(role[s]) +
                  "; expected 0 (display skin) to 4 (wound)");
      e.role = static_cast<SurfaceRole>(role[s]);
    } else if (e.label == 0 && e.name == model::kDisplaySkinName) {
      e.role = SurfaceRole::kDisplaySkin;
    } else if (e.label == 0 && e.name == model::kWoundName) {
      e.role = SurfaceRole::kWound;
    } else {
      e.role = geometry::guess_role(e.name);
    }
    e.outside = outside[s];
    const int32_t vertices = layout.vertex_count[s], faces = layout.face_count[s];
    if (vertices < 0 || faces < 0 || e.outside < 0 || e.outside > vertices)
      throw bad(surface_named(m, s) + " has " + std::to_string(vertices) + " vertices, " +
                std::to_string(faces) + " triangles and " + std::to_string(e.outside) +
                " vertices outside the tetrahedra; expected counts >= 0, at most every vertex "
                "outside");
    layout.vertices += vertices;
    layout.faces += faces;
  }
  return layout;
}

void read_embedded_points(const std::string& path, const VtuFile& f, const PieceArrays& piece,
                          const EmbeddedLayout& layout, int32_t n, bool with_offsets, Model& m) {
  const auto bad = [&](const std::string& problem) { return invalid_input(path, problem); };
  const int64_t points = n + layout.vertices;
  const auto corners = read_values<int64_t>(path, f, "PointData/embed_corners", 4 * points, 4);
  const auto weights = read_values<double>(path, f, "PointData/embed_weights", 4 * points, 4);
  const auto offsets = with_offsets
                           ? read_values<double>(path, f, "PointData/embed_offset", 3 * points, 3)
                           : std::vector<double>{};
  for (int64_t k = 0; k < 4 * static_cast<int64_t>(n); ++k)
    if (corners[k] != -1 || weights[k] != 0.0)
      throw bad("node " + std::to_string(k / 4) +
                ": embed_corners must be -1 and embed_weights 0 (a node is no embedded vertex)");
  for (int64_t k = 0; k < 3 * static_cast<int64_t>(n) && with_offsets; ++k)
    if (offsets[k] != 0.0)
      throw bad("node " + std::to_string(k / 3) +
                ": embed_offset must be 0 (a node is no embedded vertex)");

  int64_t p = n;  // the point of the file
  for (size_t s = 0; s < m.embedded.size(); ++s) {
    EmbeddedSurface& e = m.embedded[s];
    const int32_t count = layout.vertex_count[s];
    e.V.resize(count, 3);
    e.corners.resize(count, 4);
    e.weights.resize(count, 4);
    e.offsets.resize(0, 3);
    bool any_offset = false;
    if (with_offsets) e.offsets.setZero(count, 3);
    for (int32_t v = 0; v < count; ++v, ++p) {
      const std::string vertex = surface_named(m, s) + " vertex " + std::to_string(v) + ": ";
      if (piece.point_layer[p] != kEmbeddedVertexLayer || piece.mass_kg[p] != 0.0 ||
          piece.fixed[p] != 0)
        throw bad(vertex + "point " + std::to_string(p) +
                  " must have layer -2, mass_kg 0 and fixed 0 (it is no node)");
      for (int c = 0; c < 3; ++c) e.V(v, c) = piece.points[3 * p + c];
      if (!e.V.row(v).allFinite()) throw bad(vertex + "position is not finite");
      double sum = 0.0;
      for (int c = 0; c < 4; ++c) {
        const int64_t node = corners[4 * p + c];
        if (node < 0 || node >= n)
          throw bad(vertex + "corner " + std::to_string(node) + " is not a node (the model has " +
                    std::to_string(n) + ")");
        for (int d = 0; d < c; ++d)
          if (e.corners(v, d) == node)
            throw bad(vertex + "corner " + std::to_string(node) +
                      " appears twice; a tetrahedron has four distinct nodes");
        e.corners(v, c) = static_cast<int>(node);
        e.weights(v, c) = weights[4 * p + c];
        if (!std::isfinite(e.weights(v, c))) throw bad(vertex + "a weight is not finite");
        sum += e.weights(v, c);
      }
      if (!(std::abs(sum - 1.0) <= kWeightSumTolerance))
        throw bad(vertex + "weights sum to " + str(sum) + ", expected 1 (within 1e-9)");
      if (!with_offsets) continue;
      for (int c = 0; c < 3; ++c) {
        e.offsets(v, c) = offsets[3 * p + c];
        if (!std::isfinite(e.offsets(v, c))) throw bad(vertex + "an offset is not finite");
        any_offset |= e.offsets(v, c) != 0.0;
      }
      // The bound the offsets keep (model.h): a file may not extrapolate further.
      const double amplification = e.weights.row(v).cwiseAbs().sum();
      if (!(amplification <= kMaxAmplification + kWeightSumTolerance) &&
          e.offsets.row(v).squaredNorm() > 0.0)
        throw bad(vertex + "has an offset but weights whose sizes sum to " + str(amplification) +
                  ", more than " + str(kMaxAmplification));
    }
    if (!any_offset) e.offsets.resize(0, 3);  // no offset: none stored, as embed_surface makes it
  }
}

void read_embedded_cells(const std::string& path, CellWalker& cells, const EmbeddedLayout& layout,
                         int32_t n, Model& m) {
  const auto bad = [&](const std::string& problem) { return invalid_input(path, problem); };
  int64_t first = n;  // the surface's vertex 0, as a point of the file
  for (size_t s = 0; s < m.embedded.size(); ++s) {
    EmbeddedSurface& e = m.embedded[s];
    const int64_t end = first + layout.vertex_count[s];
    e.F.resize(layout.face_count[s], 3);
    const std::string expected =
        "triangle of embedded surface " + std::to_string(s) + " (type 5, kind 5)";
    for (int32_t t = 0; t < layout.face_count[s]; ++t) {
      const int64_t* corner = cells.next(3, kVtkTriangle, kCellKindEmbeddedTriangle,
                                         kCellKindEmbeddedTriangle, expected);
      for (int c = 0; c < 3; ++c) {
        if (corner[c] < first || corner[c] >= end)
          throw bad(surface_named(m, s) + " triangle " + std::to_string(t) + " uses point " +
                    std::to_string(corner[c]) + ", outside the surface's points [" +
                    std::to_string(first) + ", " + std::to_string(end) + ")");
        e.F(t, c) = static_cast<int>(corner[c] - first);
      }
      const int32_t layer = cells.piece.cell_layer[cells.cell];
      if (layer != static_cast<int32_t>(s))
        throw bad("cell " + std::to_string(cells.cell) + ": layer is " + std::to_string(layer) +
                  ", expected " + std::to_string(s) + " (its embedded surface)");
    }
    first = end;
  }
}

uint32_t embedded_fingerprint(uint32_t c, const Model& m, bool roles) {
  for (const EmbeddedSurface& e : m.embedded) c = surface_fingerprint(c, e, roles);
  return c;
}

uint32_t surface_fingerprint(uint32_t c, const EmbeddedSurface& e, bool roles) {
  c = crc(c, e.name.data(), e.name.size());
  c = crc(c, "\n", 1);  // so that no two lists of names give the same bytes
  c = crc(c, &e.label, sizeof e.label);
  if (roles) c = crc(c, &e.role, sizeof e.role);
  c = crc(c, &e.outside, sizeof e.outside);
  c = crc(c, e.V.data(), static_cast<size_t>(e.V.size()) * sizeof(double));
  c = crc(c, e.F.data(), static_cast<size_t>(e.F.size()) * sizeof(int));
  c = crc(c, e.corners.data(), static_cast<size_t>(e.corners.size()) * sizeof(int));
  c = crc(c, e.weights.data(), static_cast<size_t>(e.weights.size()) * sizeof(double));
  // Surfaces without offsets keep the checksum version 3 gave them.
  if (e.offsets.rows() > 0)
    c = crc(c, e.offsets.data(), static_cast<size_t>(e.offsets.size()) * sizeof(double));
  return c;
}

}  // namespace lamina::io::detail
