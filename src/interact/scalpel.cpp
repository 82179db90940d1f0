// Scalpels moving through a run: where each blade is at a time, and the cuts it makes as it goes.
#include "lamina/interact/scalpel.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>

#include "lamina/core/clock.h"
#include "lamina/core/error.h"

namespace lamina::interact {
namespace {

// How far back a progressive cut looks for the structures it crosses, and how far around its
// newest part: a vessel section up to about this wide is found whole.
constexpr double kStructureWindowMm = 30.0;
constexpr double kStructureReachMm = 15.0;

double path_length(const std::vector<Eigen::Vector3d>& path) {
  double length = 0.0;
  for (size_t k = 1; k < path.size(); ++k) length += (path[k] - path[k - 1]).norm();
  return length;
}

// The point at path length s.
Eigen::Vector3d point_at(const std::vector<Eigen::Vector3d>& path, double s) {
  for (size_t k = 1; k < path.size(); ++k) {
    const double l = (path[k] - path[k - 1]).norm();
    if (s <= l || k + 1 == path.size())
      return path[k - 1] + (l > 0.0 ? std::clamp(s / l, 0.0, 1.0) : 1.0) * (path[k] - path[k - 1]);
    s -= l;
  }
  return path.back();
}

// How far along its path the blade is at time t.
double reached_mm(const Scalpel& s, double length, double t) {
  return length * std::clamp((t - s.start_s) / (s.end_s - s.start_s), 0.0, 1.0);
}

// The blade's surface through columns [from, end): consecutive columns span two triangles per row.
model::Blade strip(const ScalpelDriver::Progress& p, size_t from, int32_t rows) {
  model::Blade b;
  const auto cols = static_cast<Eigen::Index>(p.columns.size() - from);
  const Eigen::Index per = rows + 1;
  b.V.resize(cols * per, 3);
  for (Eigen::Index c = 0; c < cols; ++c) b.V.middleRows(c * per, per) = p.columns[from + c];
  b.F.resize(2 * rows * std::max<Eigen::Index>(cols - 1, 0), 3);
  Eigen::Index f = 0;
  for (Eigen::Index c = 0; c + 1 < cols; ++c)
    for (Eigen::Index r = 0; r < rows; ++r) {
      const auto a = static_cast<int>(c * per + r), n = static_cast<int>(a + per);
      b.F.row(f++) << a, n, a + 1;
      b.F.row(f++) << n, n + 1, a + 1;
    }
  return b;
}

// The blade's edges at path lengths `at`, each from its point on the path `depth_mm` along the
// direction in `rows` rows, drawn at positions x and carried to rest: depth_rows + 1 points each.
Eigen::MatrixX3d columns_at_rest(const Model& model, const Eigen::MatrixX3d& x, const Scalpel& sc,
                                 const std::vector<double>& at, int32_t rows) {
  const Eigen::Vector3d dir = sc.depth_direction.normalized();
  const Eigen::Index per = rows + 1;
  Eigen::MatrixX3d world(static_cast<Eigen::Index>(at.size()) * per, 3);
  for (size_t c = 0; c < at.size(); ++c) {
    const Eigen::Vector3d top = point_at(sc.path, at[c]);
    for (Eigen::Index r = 0; r < per; ++r)
      world.row(static_cast<Eigen::Index>(c) * per + r) =
          (top + dir * (sc.depth_mm * static_cast<double>(r) / rows)).transpose();
  }
  return model::to_rest(model, x, world);
}

// Rows across a blade's depth: about one per mean edge, so that it bends with the organ.
int32_t rows_for(double depth_mm, double mean_edge_mm) {
  return std::clamp(static_cast<int32_t>(std::ceil(depth_mm / mean_edge_mm)), 1, 64);
}

// The tetrahedra's mean and longest edges at rest, mm.
struct Edges {
  double mean = 0.0, longest = 0.0;
};
Edges tet_edges(const Model& model) {
  Edges e;
  const Eigen::MatrixX4i& T = model.tets.T;
  for (Eigen::Index t = 0; t < T.rows(); ++t)
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) {
        const double l = (model.X.row(T(t, i)) - model.X.row(T(t, j))).norm();
        e.mean += l, e.longest = std::max(e.longest, l);
      }
  e.mean /= 6.0 * static_cast<double>(std::max<Eigen::Index>(T.rows(), 1));
  return e;
}

bool reported_before(const std::vector<model::StructureCut>& done, const model::StructureCut& c) {
  return std::any_of(done.begin(), done.end(), [&](const model::StructureCut& d) {
    return d.name == c.name && (d.position_mm - c.position_mm).norm() < 0.5;
  });
}

}  // namespace

ScalpelDriver make_scalpel_driver(const std::vector<Scalpel>& scalpels, const Model& model,
                                  const std::string& source) {
  for (size_t k = 0; k < scalpels.size(); ++k)
    if (const auto problem = scalpel_problem(scalpels[k]))
      throw invalid_input(source,
                          fmt::format("scalpel[{}].{}: {}", k, problem->first, problem->second));
  ScalpelDriver d;
  d.scalpels = scalpels;
  d.progress.resize(scalpels.size());
  if (scalpels.empty()) return d;
  if (!model.has_tets())
    throw invalid_input(source,
                        "tools: a scalpel cuts the tetrahedra, and the model has none (build it "
                        "with model.build.structure \"tetrahedra\", the default)");
  const Edges edges = tet_edges(model);
  d.event_mm = edges.mean;
  d.reach_mm = 2.0 * edges.longest;
  double depth = 0.0;
  for (const Scalpel& s : scalpels) depth = std::max(depth, s.depth_mm);
  d.depth_rows = rows_for(depth, edges.mean);
  return d;
}

bool scalpels_active(const ScalpelDriver& d, double time_s) {
  for (size_t k = 0; k < d.scalpels.size(); ++k) {
    const double length = path_length(d.scalpels[k].path);
    if (d.progress[k].done_mm < length - 1e-9 * length && time_s <= d.scalpels[k].end_s + 1e-9)
      return true;
  }
  return false;
}

std::vector<CutEvent> advance_scalpels(ScalpelDriver& d, std::shared_ptr<const Model>& model,
                                       sim::Simulation& sim, ToolDriver& driver,
                                       std::vector<int32_t>* origin_out) {
  std::vector<CutEvent> events;
  if (origin_out != nullptr) {
    origin_out->resize(static_cast<size_t>(model->node_count()));
    std::iota(origin_out->begin(), origin_out->end(), 0);
  }
  for (size_t k = 0; k < d.scalpels.size(); ++k) {
    const Scalpel& sc = d.scalpels[k];
    ScalpelDriver::Progress& p = d.progress[k];
    const double length = path_length(sc.path);
    if (sim.time_s < sc.start_s || p.done_mm >= length) continue;
    const double now = reached_mm(sc, length, sim.time_s);
    const bool finished = now >= length;
    if (p.done_mm >= 0.0 && now - p.done_mm < d.event_mm && !finished) continue;
    const auto t0 = Clock::now();

    // The new columns: the path's corners passed since the last cut, and where the blade is.
    std::vector<double> at;
    if (p.done_mm < 0.0) at.push_back(0.0);
    double corner = 0.0;
    for (size_t c = 1; c + 1 < sc.path.size(); ++c) {
      corner += (sc.path[c] - sc.path[c - 1]).norm();
      if (corner > std::max(p.done_mm, 0.0) && corner < now) at.push_back(corner);
    }
    if (now > std::max(p.done_mm, 0.0)) at.push_back(now);
    if (p.done_mm < 0.0) {  // this scalpel begins
      bool alone = true;
      for (size_t j = 0; j < d.scalpels.size(); ++j)
        alone = alone && (j == k || d.progress[j].done_mm < 0.0 ||
                          d.progress[j].done_mm >= path_length(d.scalpels[j].path));
      if (alone) p.unsplit = std::make_shared<const std::vector<EmbeddedSurface>>(model->embedded);
    }
    const Eigen::Index per = d.depth_rows + 1;
    const Eigen::MatrixX3d rest = columns_at_rest(*model, sim.x, sc, at, d.depth_rows);
    const size_t first_new = p.columns.size();
    for (size_t c = 0; c < at.size(); ++c) {
      p.columns.push_back(rest.middleRows(static_cast<Eigen::Index>(c) * per, per));
      p.s.push_back(at[c]);
    }
    p.done_mm = now;
    if (p.columns.size() < 2) continue;

    // The cut sweeps the blade's recent path again (reach_mm): the tetrahedra its tip was in
    // at the last cut are divided now that it has passed through them.
    const double back = p.s[std::max<size_t>(first_new, 1) - 1] - d.reach_mm;
    size_t from = first_new > 0 ? first_new - 1 : 0;
    while (from > 0 && p.s[from] > back) --from;
    const model::Blade blade = strip(p, from, d.depth_rows);

    // The structures crossed, looked for at rest along the last kStructureWindowMm of the
    // path, near its newest part; each reported once, when its section closes (or, where the
    // blade stops inside one, at the end).
    // At the end, along the whole path: a section longer than the window (a vessel the blade
    // runs along, a gallbladder crossed lengthwise) never closed inside it and went unreported.
    size_t wfrom = from;
    while (wfrom > 0 && p.s[wfrom] > now - kStructureWindowMm) --wfrom;
    if (finished) wfrom = 0;
    Eigen::AlignedBox3d newest;
    for (size_t c = finished ? 0 : (first_new > 0 ? first_new - 1 : 0); c < p.columns.size(); ++c)
      for (Eigen::Index r = 0; r < per; ++r) newest.extend(p.columns[c].row(r).transpose());
    if (!d.uncut) d.uncut = model;
    std::vector<model::StructureCut> crossed = model::structures_crossed(
        *d.uncut, d.uncut->X, strip(p, wfrom, d.depth_rows),
        newest.min().array() - kStructureReachMm, newest.max().array() + kStructureReachMm);

    CutEvent e;
    e.time_s = sim.time_s;
    e.scalpel = static_cast<int32_t>(k);
    std::vector<int32_t> origin;
    // The blade's tip stays whole until the blade has passed through it (at its end, the cut
    // ends there).
    model::CutOptions options{.find_structures = false};  // `crossed`, found above
    const model::Blade whole = p.unsplit ? strip(p, 0, d.depth_rows) : model::Blade{};
    // The part the surfaces have not been split along: from the last column they were.
    const model::Blade fresh = p.unsplit && p.split_columns > 0
                                   ? strip(p, p.split_columns - 1, d.depth_rows)
                                   : model::Blade{};
    if (p.unsplit) options.unsplit = p.unsplit.get(), options.unsplit_blade = &whole;
    if (p.unsplit && p.split_columns > 0) options.unsplit_new = &fresh;
    if (!finished) {
      options.tip_from = p.columns.back().row(0).transpose();
      options.tip_to = p.columns.back().row(d.depth_rows).transpose();
    }
    e.report = cut_simulation(model, sim, driver, blade, origin, options);
    if (p.unsplit && e.report.changed()) p.split_columns = p.columns.size();
    if (origin_out != nullptr && e.report.changed()) {  // this cut's origin after the last's
      for (int32_t& o : origin) o = (*origin_out)[static_cast<size_t>(o)];
      *origin_out = std::move(origin);
    }
    for (model::StructureCut& c : crossed) {
      if (!(c.closed || finished) || reported_before(p.reported, c)) continue;
      p.reported.push_back(c);
      // Where it is now, for a marker and a log.
      c.position_mm = model::from_rest(*model, sim.x, c.position_mm.transpose()).row(0).transpose();
      e.report.structures_cut.push_back(c);
    }
    e.seconds = seconds_since(t0);
    if (e.report.changed() || !e.report.structures_cut.empty()) events.push_back(e);
  }
  return events;
}

namespace {

// The blade of a cut made at once, drawn at positions x and carried to rest: columns at the
// path's points, and between them about one a mean edge apart.
model::Blade blade_now(const Model& model, const Eigen::MatrixX3d& x,
                       const std::vector<Eigen::Vector3d>& path, const Eigen::Vector3d& direction,
                       double depth_mm) {
  const Scalpel sc{.path = path, .depth_direction = direction, .depth_mm = depth_mm};
  if (const auto problem = scalpel_problem(sc))
    throw invalid_input("cut: " + problem->first, problem->second);
  if (!model.has_tets())
    throw invalid_input("cut",
                        "the model has no tetrahedra (built with --structure links): "
                        "only a model with tetrahedra can be cut");
  const double mean = tet_edges(model).mean, length = path_length(path);
  std::vector<double> at;
  double s = 0.0;
  for (size_t k = 0; k < path.size(); ++k) {
    if (k > 0) {
      const double l = (path[k] - path[k - 1]).norm();
      const int steps = std::clamp(static_cast<int>(std::ceil(l / mean)), 1, 10000);
      for (int q = 1; q < steps; ++q) at.push_back(s + l * q / steps);
      s += l;
    }
    at.push_back(std::min(s, length));
  }
  const int32_t rows = rows_for(depth_mm, mean);
  ScalpelDriver::Progress p;
  const Eigen::MatrixX3d rest = columns_at_rest(model, x, sc, at, rows);
  for (size_t c = 0; c < at.size(); ++c)
    p.columns.push_back(rest.middleRows(static_cast<Eigen::Index>(c) * (rows + 1), rows + 1));
  return strip(p, 0, rows);
}

}  // namespace

model::CutReport cut_model_now(const Model& model, const Eigen::MatrixX3d& x,
                               const std::vector<Eigen::Vector3d>& path,
                               const Eigen::Vector3d& direction, double depth_mm, Model& cut,
                               std::vector<int32_t>& origin) {
  const model::Blade blade = blade_now(model, x, path, direction, depth_mm);
  model::CutReport report;
  model::cut_tetrahedra(model, model.X, blade, cut, origin, report);
  if (report.cut_tets == 0) {
    cut = Model{};
    origin.resize(static_cast<size_t>(model.node_count()));
    for (size_t i = 0; i < origin.size(); ++i) origin[i] = static_cast<int32_t>(i);
  }
  return report;
}

model::CutReport cut_now(std::shared_ptr<const Model>& model, sim::Simulation& sim,
                         ToolDriver& driver, const std::vector<Eigen::Vector3d>& path,
                         const Eigen::Vector3d& direction, double depth_mm,
                         std::vector<int32_t>& origin) {
  const model::Blade blade = blade_now(*model, sim.x, path, direction, depth_mm);
  model::CutReport report = cut_simulation(model, sim, driver, blade, origin);
  for (model::StructureCut& c : report.structures_cut)
    c.position_mm = model::from_rest(*model, sim.x, c.position_mm.transpose()).row(0).transpose();
  return report;
}

}  // namespace lamina::interact
