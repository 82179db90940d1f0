// The model file's cut part (format version 5): the share of its material each spring and
// tetrahedron carries after a cut, and which corners' material each tetrahedron carries
// (Springs::share, Tets::share, Tets::material; docs/model_format.md). Without them a cut model
// would load as an uncut one whose divided tetrahedra count their material twice.

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "lamina/core/error.h"
#include "model_file_internal.h"

namespace lamina::io::detail {

bool is_cut(const Model& m) {
  return !m.tets.share.empty() || !m.tets.material.empty() || !m.springs.share.empty();
}

void check_cut_savable(const Model& m, const std::string& path) {
  const bool ok =
      (m.tets.share.empty() || m.tets.share.size() == static_cast<size_t>(m.tets.size())) &&
      (m.tets.material.empty() || m.tets.material.size() == static_cast<size_t>(m.tets.size())) &&
      (m.springs.share.empty() || m.springs.share.size() == m.springs.size());
  if (!ok)
    throw Error(ErrorKind::kInternal,
                path + ": cannot save: the cut model's shares disagree in size with its cells");
}

void write_cut_cell_data(std::ostream& out, const char* indent, const Model& m, int64_t cells) {
  if (!is_cut(m)) return;
  // Every cell has a value (VTK's CellData): 1 and 15 (all) for the triangles.
  std::vector<double> share(static_cast<size_t>(cells), 1.0);
  std::vector<uint8_t> material(static_cast<size_t>(cells), 15);
  int64_t cell = 0;
  for (const ModelLayer& l : m.layers) cell += l.F.rows();
  for (size_t e = 0; e < m.springs.size(); ++e)
    share[static_cast<size_t>(cell++)] = m.springs.share_of(e);
  for (int64_t t = 0; t < m.tets.size(); ++t, ++cell) {
    share[static_cast<size_t>(cell)] = m.tets.share_of(t);
    material[static_cast<size_t>(cell)] = m.tets.material_of(t);
  }
  write_array(out, indent, "share", share);
  write_array(out, indent, "material", material);
}

void read_cut_cells(const std::string& path, const VtuFile& f, int64_t cells, int64_t first_spring,
                    int64_t first_tet, int64_t first_embedded, Model& m) {
  const std::vector<double> share = read_values<double>(path, f, "CellData/share", cells);
  const std::vector<uint8_t> material = read_values<uint8_t>(path, f, "CellData/material", cells);
  const auto bad = [&](int64_t cell, const std::string& problem) {
    return invalid_input(path, "cell " + std::to_string(cell) + ": " + problem);
  };
  for (int64_t c = 0; c < cells; ++c) {
    const bool tet = c >= first_tet && c < first_embedded;
    const bool spring = c >= first_spring && c < first_tet;
    const double s = share[static_cast<size_t>(c)];
    const uint8_t k = material[static_cast<size_t>(c)];
    if (!(tet || spring) && (s != 1.0 || k != 15))
      throw bad(c, "a triangle's share must be 1 and its material 15, found " + str(s) + " and " +
                       std::to_string(k));
    if (!(std::isfinite(s) && s > 0.0 && s <= 1.0))
      throw bad(c, "share is " + str(s) + ", must lie in (0, 1]");
    if (tet ? (k < 1 || k > 15) : k != 15)
      throw bad(c, "material is " + std::to_string(k) +
                       (tet ? ", must name corners 1 to 15" : ", must be 15 for a spring"));
  }
  m.springs.share.assign(share.begin() + first_spring, share.begin() + first_tet);
  m.tets.share.assign(share.begin() + first_tet, share.begin() + first_embedded);
  m.tets.material.assign(material.begin() + first_tet, material.begin() + first_embedded);
}

uint32_t cut_fingerprint(uint32_t c, const Model& m) {
  if (!is_cut(m)) return c;  // uncut models keep the checksum they had
  for (size_t e = 0; e < m.springs.size(); ++e) {
    const double s = m.springs.share_of(e);
    c = crc(c, &s, sizeof s);
  }
  for (int64_t t = 0; t < m.tets.size(); ++t) {
    const double s = m.tets.share_of(t);
    const uint8_t k = m.tets.material_of(t);
    c = crc(c, &s, sizeof s);
    c = crc(c, &k, 1);
  }
  return c;
}

}  // namespace lamina::io::detail
