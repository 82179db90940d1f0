// The checkpoint's scalpel section (version 2; roles from version 3; from version 4 whether an
// event split only the fine surfaces; from version 5 how far a scalpel's surfaces are split): the
// cut model as a model file's text (so that load_model()'s checks vouch for it), the support and
// tool vertices the cuts carried over, and each scalpel's progress, whose blade columns at rest and
// surfaces as they were before it cut a resumed run needs to go on cutting exactly as the run it
// continues would have.
#include <sstream>
#include <string>
#include <utility>

#include "checkpoint_internal.h"
#include "lamina/geometry/structure_names.h"
#include "lamina/model/compute_rings.h"
#include "lamina/model/cut_tetrahedra.h"
#include "lamina/model/embed_surface.h"
#include "model_file_internal.h"

namespace lamina::io::checkpoint_detail {
namespace {

// Files before version 3 hold no roles: the role the readers of their time saw in the name.
SurfaceRole legacy_role(const std::string& name, int32_t label) {
  if (label == 0 && name == model::kDisplaySkinName) return SurfaceRole::kDisplaySkin;
  if (label == 0 && name == model::kWoundName) return SurfaceRole::kWound;
  return geometry::guess_role(name);
}

SurfaceRole read_role(Reader& r, const std::string& name, int32_t label) {
  if (r.version < 3) return legacy_role(name, label);
  const auto role = r.pod<uint8_t>();
  if (role > static_cast<uint8_t>(SurfaceRole::kWound))
    throw invalid_input(r.path, "checkpoint is inconsistent: " + name.substr(0, 40) + " has role " +
                                    std::to_string(role));
  return static_cast<SurfaceRole>(role);
}

void write_surface(Writer& w, const EmbeddedSurface& e) {
  w.str(e.name);
  w.pod(e.label);
  w.pod(static_cast<uint8_t>(e.role));
  w.pod(e.outside);
  w.matrix(e.V);
  w.matrix(e.F);
  w.matrix(e.corners);
  w.matrix(e.weights);
  w.matrix(e.offsets);
}

EmbeddedSurface read_surface(Reader& r) {
  EmbeddedSurface e;
  e.name = r.str();
  e.label = r.pod<int32_t>();
  e.role = read_role(r, e.name, e.label);
  e.outside = r.pod<int32_t>();
  e.V = r.matrix<Eigen::MatrixX3d>();
  e.F = r.matrix<Eigen::MatrixX3i>();
  e.corners = r.matrix<Eigen::MatrixX4i>();
  e.weights = r.matrix<Eigen::MatrixX4d>();
  e.offsets = r.matrix<Eigen::MatrixX3d>();
  const Eigen::Index n = e.V.rows();
  const bool ok = e.corners.rows() == n && e.weights.rows() == n &&
                  (e.offsets.rows() == 0 || e.offsets.rows() == n) && e.V.allFinite() &&
                  e.weights.allFinite() &&
                  (e.F.size() == 0 || (e.F.minCoeff() >= 0 && e.F.maxCoeff() < n));
  if (!ok)
    throw invalid_input(r.path, "checkpoint is inconsistent: a scalpel's surface " +
                                    e.name.substr(0, 40) + " has arrays that disagree");
  return e;
}

void write_structure(Writer& w, const model::StructureCut& c) {
  w.str(c.name);
  w.pod(c.label);
  w.pod(static_cast<uint8_t>(c.role));
  w.bytes(c.position_mm.data(), 3 * sizeof(double));
  w.pod(c.area_mm2);
  w.pod(c.diameter_mm);
  w.pod<uint8_t>(c.closed ? 1 : 0);
}

model::StructureCut read_structure(Reader& r) {
  model::StructureCut c;
  c.name = r.str();
  c.label = r.pod<int32_t>();
  c.role = read_role(r, c.name, c.label);
  r.take(c.position_mm.data(), 3 * sizeof(double));
  c.area_mm2 = r.pod<double>();
  c.diameter_mm = r.pod<double>();
  c.closed = r.pod<uint8_t>() != 0;
  return c;
}

template <class T, class Write>
void write_list(Writer& w, const std::vector<T>& list, Write write) {
  w.pod<uint64_t>(list.size());
  for (const T& x : list) write(w, x);
}

// A list of at least `least` bytes an element (so a hostile count is refused before allocating).
template <class T, class Read>
std::vector<T> read_list(Reader& r, size_t least, Read read) {
  std::vector<T> list(r.count(least));
  for (T& x : list) x = read(r);
  return list;
}

}  // namespace

void write_scalpels(Writer& w, const ScalpelCheckpoint& k) {
  w.pod<uint8_t>(k.model ? 1 : 0);
  if (k.model) {
    std::ostringstream text;
    detail::write_model(*k.model, "checkpoint", text);
    w.str(text.str());
  }
  w.vec(k.support_n_per_m);
  w.pod<uint8_t>(k.multigrid ? 1 : 0);
  w.vec(k.tool_vertex);
  w.mat(k.held_forces);
  write_list(w, k.progress, [](Writer& o, const interact::ScalpelDriver::Progress& p) {
    o.pod(p.done_mm);
    o.vec(p.s);
    write_list(o, p.columns, [](Writer& q, const Eigen::MatrixX3d& c) { q.mat(c); });
    write_list(o, p.reported, write_structure);
    o.pod<uint8_t>(p.unsplit ? 1 : 0);
    if (p.unsplit) write_list(o, *p.unsplit, write_surface);
    o.pod<uint64_t>(p.split_columns);
  });
  write_list(w, k.events, [](Writer& o, const interact::CutEvent& e) {
    o.pod(e.time_s);
    o.pod(e.scalpel);
    o.pod(e.seconds);
    o.pod(e.report.cut_tets);
    o.pod(e.report.partly_cut_tets);
    o.pod(e.report.new_nodes);
    o.vec(e.report.pieces);
    write_list(o, e.report.structures_cut, write_structure);
    o.pod<uint8_t>(e.report.surfaces_split ? 1 : 0);
  });
}

ScalpelCheckpoint read_scalpels(Reader& r) {
  ScalpelCheckpoint k;
  if (r.pod<uint8_t>() != 0) {
    Model m = detail::parse_model(r.path + " (the cut model in it)", r.str());
    m.rings = model::compute_rings(m, m.rings.locality);  // not stored: they follow the layers
    k.model = std::make_shared<const Model>(std::move(m));
  }
  k.support_n_per_m = r.vec<double>();
  k.multigrid = r.pod<uint8_t>() != 0;
  k.tool_vertex = r.vec<int32_t>();
  k.held_forces = r.mat();
  k.progress = read_list<interact::ScalpelDriver::Progress>(r, 8 + 3 * 8 + 1, [](Reader& q) {
    interact::ScalpelDriver::Progress p;
    p.done_mm = q.pod<double>();
    p.s = q.vec<double>();
    p.columns = read_list<Eigen::MatrixX3d>(q, 8, [](Reader& c) { return c.mat(); });
    p.reported = read_list<model::StructureCut>(q, 8, read_structure);
    if (q.pod<uint8_t>() != 0)
      p.unsplit = std::make_shared<const std::vector<EmbeddedSurface>>(
          read_list<EmbeddedSurface>(q, 8, read_surface));
    // (Before version 5 not kept: the next cut splits the surfaces along the whole path again.)
    if (q.version >= 5) p.split_columns = q.pod<uint64_t>();
    if (p.split_columns > p.columns.size())
      throw invalid_input(q.path,
                          "checkpoint is inconsistent: a scalpel's surfaces are split "
                          "along " +
                              std::to_string(p.split_columns) + " of its " +
                              std::to_string(p.columns.size()) + " columns");
    if (p.s.size() != p.columns.size())
      throw invalid_input(q.path, "checkpoint is inconsistent: a scalpel's blade has " +
                                      std::to_string(p.columns.size()) + " columns and " +
                                      std::to_string(p.s.size()) + " positions");
    return p;
  });
  k.events = read_list<interact::CutEvent>(r, 8 * 6, [](Reader& q) {
    interact::CutEvent e;
    e.time_s = q.pod<double>();
    e.scalpel = q.pod<int32_t>();
    e.seconds = q.pod<double>();
    e.report.cut_tets = q.pod<int64_t>();
    e.report.partly_cut_tets = q.pod<int64_t>();
    e.report.new_nodes = q.pod<int32_t>();
    e.report.pieces = q.vec<model::CutPiece>();
    e.report.structures_cut = read_list<model::StructureCut>(q, 8, read_structure);
    if (q.version >= 4) e.report.surfaces_split = q.pod<uint8_t>() != 0;
    return e;
  });
  return k;
}

}  // namespace lamina::io::checkpoint_detail
