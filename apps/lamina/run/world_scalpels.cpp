#include "world_scalpels.h"

#include <fmt/format.h>

#include <algorithm>

#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/world/cut_body.h"

namespace lamina::cli {

std::vector<BodyScalpels> world_scalpels(const io::ReadyWorld& w, const std::string& source) {
  std::vector<BodyScalpels> out(w.ids.size());
  for (size_t b = 0; b < w.ids.size(); ++b) {
    const world::Body& body = world::body(w.world, w.ids[b]);
    out[b].driver =
        interact::make_scalpel_driver(w.bodies[b].scene.scalpels, *body.model,
                                      fmt::format("{}: bodies[{}] ('{}')", source, b, body.name));
  }
  return out;
}

double scalpels_end_s(const std::vector<BodyScalpels>& scalpels) {
  double t = 0.0;
  for (const BodyScalpels& b : scalpels)
    for (const interact::Scalpel& sc : b.driver.scalpels) t = std::max(t, sc.end_s);
  return t;
}

std::vector<size_t> advance_world_scalpels(io::ReadyWorld& w, std::vector<BodyScalpels>& scalpels) {
  std::vector<size_t> changed;
  for (size_t b = 0; b < scalpels.size(); ++b) {
    BodyScalpels& s = scalpels[b];
    if (s.driver.scalpels.empty()) continue;
    const uint32_t topology = world::body(w.world, w.ids[b]).topology;
    for (const interact::CutEvent& e : world::advance_scalpels(w.world, w.ids[b], s.driver)) {
      const std::string& name = world::body(w.world, w.ids[b]).name;
      for (const model::StructureCut& c : e.report.structures_cut) {
        log::warn(
            "t = {:.3f} s: the scalpel cut {}'s {} across at ({:.1f}, {:.1f}, {:.1f}) mm, "
            "{:.1f} mm wide{}",
            e.time_s, name, c.name, c.position_mm.x(), c.position_mm.y(), c.position_mm.z(),
            c.diameter_mm, c.closed ? "" : " (the blade stopped inside it)");
        s.structures_cut.push_back(c.name);
      }
      if (e.report.cut_tets == 0 && e.report.surfaces_split)
        log::debug("t = {:.3f} s: past {}'s tissue, the structures beside it split, in {:.1f} ms",
                   e.time_s, name, 1e3 * e.seconds);
      if (e.report.cut_tets == 0) continue;
      log::debug("t = {:.3f} s: cut {} tetrahedra of {}, {} new nodes, in {:.1f} ms", e.time_s,
                 e.report.cut_tets, name, e.report.new_nodes, 1e3 * e.seconds);
      ++s.cuts;
      s.cut_tets += e.report.cut_tets;
      s.new_nodes += e.report.new_nodes;
    }
    if (world::body(w.world, w.ids[b]).topology != topology) changed.push_back(b);
  }
  return changed;
}

}  // namespace lamina::cli
