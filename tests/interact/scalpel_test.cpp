// A scalpel drawn through a running simulation (issue 47): cut as it goes, the cut it leaves is
// the one a single cut along its whole path makes, wherever the organ has moved, with the mass
// and the tools' loads kept.
#include "lamina/interact/scalpel.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <map>
#include <numeric>
#include <set>
#include <string>
#include <thread>

#include "lamina/core/error.h"
#include "lamina/geometry/mesh_measures.h"
#include "lamina/interact/run_tools.h"
#include "support/embedded_phantom.h"
#include "support/phantom_across.h"
#include "support/surface_parts.h"
#include "support/tet_phantom.h"
#include "support/totalseg_anatomy.h"

namespace {

using namespace lamina;

using test::across;
using test::Across;

model::CutReport one_cut(const Across& s) {
  Model out;
  std::vector<int32_t> origin;
  model::CutReport r;
  const Model& m = test::tet_phantom();
  model::cut_tetrahedra(
      m, m.X, model::sweep_blade(s.scalpel.path, s.scalpel.depth_direction, s.scalpel.depth_mm),
      out, origin, r);
  return r;
}

double total_mass(const sim::Simulation& s) {
  return std::accumulate(s.mass_kg().begin(), s.mass_kg().end(), 0.0);
}

sim::Simulation held() {
  return test::held_phantom();
}

TEST(Scalpel, CutAsItGoesLeavesTheCutOfItsWholePath) {
  const Across s = across();
  const model::CutReport whole = one_cut(s);
  ASSERT_EQ(whole.pieces.size(), 2u);

  auto model = std::make_shared<const Model>(test::tet_phantom());
  sim::Simulation sim = held();
  const double mass = total_mass(sim);
  interact::ToolDriver tools;
  interact::ScalpelDriver scalpels = interact::make_scalpel_driver(std::vector{s.scalpel}, *model);
  std::vector<interact::CutEvent> events;
  int64_t cut_tets = 0;
  for (int k = 0; k < 150; ++k) {
    for (const interact::CutEvent& e : interact::advance_scalpels(scalpels, model, sim, tools)) {
      events.push_back(e);
      cut_tets += e.report.cut_tets;
    }
    ASSERT_EQ(sim::step(sim).unstable, sim::Instability::kNone) << "step " << k;
  }
  EXPECT_FALSE(interact::scalpels_active(scalpels, sim.time_s));
  ASSERT_GT(events.size(), 3u) << "the blade cut once, not as it went";
  const model::CutReport& last = events.back().report;
  ASSERT_EQ(last.pieces.size(), 2u);
  // The same tetrahedra divided, give or take those its tip ended in between two cuts and a
  // later cut divided once it had passed, at another state of the organ: within 2%.
  EXPECT_NEAR(static_cast<double>(cut_tets), static_cast<double>(whole.cut_tets),
              0.02 * static_cast<double>(whole.cut_tets));
  for (size_t p = 0; p < 2; ++p)
    EXPECT_NEAR(last.pieces[p].volume_mm3, whole.pieces[p].volume_mm3,
                0.01 * whole.pieces[p].volume_mm3);
  EXPECT_NEAR(total_mass(sim), mass, 1e-9 * mass);
  EXPECT_EQ(sim.model().node_count(), model->node_count());
  EXPECT_EQ(sim::inverted_tets(*model, sim.x), 0);
  std::printf("%zu cuts as the blade went, %lld tetrahedra divided (one cut: %lld)\n",
              events.size(), static_cast<long long>(cut_tets),
              static_cast<long long>(whole.cut_tets));
}

// A scalpel drawn across an organ with its anatomy along the plane x = x0 through everything (the
// organ and the structures' boxes), the organ held at its back, stepped until the blade is
// through: the model it leaves and the cut events. `afresh_each_event`: the driver told before
// each event that the surfaces are split along none of the path (so split along all of it).
struct Progressive {
  std::shared_ptr<const Model> model;
  std::vector<interact::CutEvent> events;
};

Progressive cut_progressively(const Model& m0, double x0, bool afresh_each_event = false) {
  Eigen::Vector3d lo = m0.X.colwise().minCoeff(), hi = m0.X.colwise().maxCoeff();
  for (const EmbeddedSurface& s : m0.embedded) {
    lo = lo.cwiseMin(s.V.colwise().minCoeff().transpose());
    hi = hi.cwiseMax(s.V.colwise().maxCoeff().transpose());
  }
  interact::Scalpel blade;
  blade.path = {Eigen::Vector3d(x0, lo.y() - 5, lo.z() - 5),
                Eigen::Vector3d(x0, hi.y() + 5, lo.z() - 5)};
  blade.depth_direction = Eigen::Vector3d::UnitZ();
  blade.depth_mm = hi.z() - lo.z() + 10;
  blade.end_s = 0.1;
  Progressive out{std::make_shared<const Model>(m0), {}};
  sim::Simulation sim =
      sim::make_simulation(m0, test::kTetLiver, {.integrator = sim::Integrator::kImplicitEuler});
  sim::fix_nodes(sim, test::posterior_nodes(m0));
  interact::ToolDriver tools;
  interact::ScalpelDriver scalpels = interact::make_scalpel_driver(std::vector{blade}, m0);
  for (int k = 0; k < 150; ++k) {
    if (afresh_each_event)
      for (interact::ScalpelDriver::Progress& p : scalpels.progress) p.split_columns = 0;
    for (interact::CutEvent& e : interact::advance_scalpels(scalpels, out.model, sim, tools))
      out.events.push_back(std::move(e));
    EXPECT_EQ(sim::step(sim).unstable, sim::Instability::kNone) << "step " << k;
  }
  return out;
}

// That scalpel, cutting as it goes: at each event the display skin and the structures as they
// were when it began are split along its path's new part, what earlier events made kept (where
// the tissue has not opened yet, at its tip, welded again), and at the end every piece's surfaces
// are closed, none has a triangle across the cut or on both pieces, each triangle follows the
// piece on its side, and together they enclose what they did.
void expect_progressive_cut_splits(const Model& m0, double x0, const std::string& crossed) {
  const Progressive run = cut_progressively(m0, x0);
  const int events = static_cast<int>(run.events.size());
  int structures = 0;
  for (const interact::CutEvent& e : run.events)
    for (const model::StructureCut& c : e.report.structures_cut) structures += c.name == crossed;
  ASSERT_GT(events, 3);
  EXPECT_GE(structures, 1) << crossed << ", crossed, is reported";
  const Model& m = *run.model;
  const std::vector<int32_t> piece = test::piece_of_nodes(m);
  ASSERT_EQ(std::set<int32_t>(piece.begin(), piece.end()).size(), 2u);
  Eigen::Index lowest;
  m.X.col(0).minCoeff(&lowest);
  for (size_t e = 0; e < m0.embedded.size(); ++e) {
    const EmbeddedSurface &before = m0.embedded[e], &s = m.embedded[e];
    const test::SurfaceParts a = test::surface_parts(s, piece, x0);
    EXPECT_EQ(a.straddling, 0) << s.name << ": triangles across the cut";
    EXPECT_EQ(a.on_two, 0) << s.name << ": triangles on both pieces";
    EXPECT_EQ(a.open_edges, 0) << s.name << ": a piece's part is not closed";
    int other_side = 0;
    for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
      double x = 0.0;
      for (int k = 0; k < 3; ++k) x += s.V(s.F(f, k), 0) / 3.0;
      if (std::abs(x - x0) < 1e-6) continue;  // a cap
      other_side += (piece[s.corners(s.F(f, 0), 0)] == piece[lowest]) != (x < x0);
    }
    EXPECT_EQ(other_side, 0) << s.name << ": triangles following the piece across the cut";
    double total = 0.0;
    for (const auto& [p, v] : a.volume) {
      EXPECT_GT(v, 0.0) << s.name << " piece " << p << " faces inward";
      total += v;
    }
    const double v0 = geometry::enclosed_volume(SurfaceMesh{before.V, before.F});
    std::printf("%s: %zu piece(s), %lld -> %lld triangles, %.1f -> %.1f mm^3\n", s.name.c_str(),
                a.volume.size(), static_cast<long long>(before.F.rows()),
                static_cast<long long>(s.F.rows()), v0, total);
    EXPECT_NEAR(total, v0, 1e-6 * v0) << s.name;
  }
}

TEST(Scalpel, AProgressiveCutSplitsTheFineSurfacesIntoClosedPieces) {
  const Model& m0 = test::embedded_phantom();
  expect_progressive_cut_splits(m0, m0.X.col(0).mean() + 0.31, "vessels");
}

// The same on TotalSegmentator's liver with its portal and splenic vein, vena cava and
// gallbladder, which lie beside the liver (most of their vertices follow the nearest tetrahedra
// by an offset). Through the vena cava, the blade leaves the tissue while still inside the vein
// (it runs along the liver's back, beyond it): the events past the tissue divide no tetrahedra
// but split the vein (before, its part beyond stayed whole, stretched between the pieces: 408
// open edges, 14 triangles on both). Both sections are longer than the 30 mm the driver looks
// back for a closed one: they are reported at the end (before, never).
TEST(Scalpel, AProgressiveCutSplitsARealLiversStructuresBesideItIntoClosedPieces) {
  const Model m0 = test::totalseg_anatomy();
  {
    SCOPED_TRACE("through the gallbladder");
    expect_progressive_cut_splits(m0, m0.X.col(0).mean() + 0.37, "gallbladder");
  }
  SCOPED_TRACE("through the vena cava and the portal vein");
  expect_progressive_cut_splits(m0, -12.37, "vena_cava");
}

// A progressive cut splits the surfaces along its path's new part only, keeping what earlier
// events made elsewhere (model::CutOptions::unsplit_new): what it leaves is what splitting them
// afresh along the whole path at every event leaves (the driver told, before each event, that
// nothing is split yet): the same vertices and triangles, each on the same piece, the same
// volumes. A seam where the two parts meet that joined the wrong copies, a sub-triangle left
// twice or a section's cap lost would differ.
void expect_new_part_split_as_whole(const Model& m0, double x0) {
  const Model part = *cut_progressively(m0, x0).model,
              whole = *cut_progressively(m0, x0, true).model;
  ASSERT_EQ(part.node_count(), whole.node_count()) << "the same tetrahedra divided";
  const std::vector<int32_t> piece = test::piece_of_nodes(whole);
  ASSERT_EQ(piece, test::piece_of_nodes(part));
  ASSERT_EQ(part.embedded.size(), whole.embedded.size());
  for (size_t e = 0; e < whole.embedded.size(); ++e) {
    const EmbeddedSurface &a = part.embedded[e], &b = whole.embedded[e];
    SCOPED_TRACE(b.name);
    EXPECT_EQ(a.V.rows(), b.V.rows());
    EXPECT_EQ(a.F.rows(), b.F.rows());
    const auto ta = test::triangle_keys(a, piece), tb = test::triangle_keys(b, piece);
    size_t differ = ta.size() == tb.size() ? 0 : std::max(ta.size(), tb.size());
    for (size_t k = 0; k < ta.size() && k < tb.size(); ++k) differ += ta[k] != tb[k];
    EXPECT_EQ(differ, 0u) << "triangles that differ (or sit on another piece)";
    const test::SurfaceParts pa = test::surface_parts(a, piece, x0),
                             pb = test::surface_parts(b, piece, x0);
    EXPECT_EQ(pa.open_edges, pb.open_edges);
    for (const auto& [p, v] : pb.volume)
      EXPECT_NEAR(pa.volume.count(p) ? pa.volume.at(p) : 0.0, v, 1e-9 * std::abs(v) + 1e-9);
  }
}

TEST(Scalpel, SplittingAlongTheNewPartOnlyLeavesWhatSplittingTheWholePathAfreshWould) {
  {
    SCOPED_TRACE("the phantom with its vessels and tumour");
    const Model& m0 = test::embedded_phantom();
    expect_new_part_split_as_whole(m0, m0.X.col(0).mean() + 0.31);
  }
  SCOPED_TRACE("TotalSegmentator's liver through the gallbladder");
  const Model m0 = test::totalseg_anatomy();
  expect_new_part_split_as_whole(m0, m0.X.col(0).mean() + 0.37);
}

TEST(Scalpel, AMovedOrganIsCutWhereItsMaterialIs) {
  // The organ turned and shifted, the blade drawn on it where it now is: the material cut is
  // the material at rest under the blade's path carried back.
  Across s = across();
  const model::CutReport whole = one_cut(s);
  auto model = std::make_shared<const Model>(test::tet_phantom());
  sim::Simulation sim = held();
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).matrix();
  const Eigen::Vector3d shift(12.0, -7.0, 3.0);
  for (Eigen::Index i = 0; i < sim.x.rows(); ++i)
    sim.x.row(i) = (R * model->X.row(i).transpose() + shift).transpose();
  for (Eigen::Vector3d& p : s.scalpel.path) p = R * p + shift;
  s.scalpel.depth_direction = R * s.scalpel.depth_direction;
  s.scalpel.end_s = 0.0 + 1e-9;  // the whole path at once
  interact::ToolDriver tools;
  interact::ScalpelDriver scalpels = interact::make_scalpel_driver(std::vector{s.scalpel}, *model);
  sim.time_s = 1.0;
  const std::vector<interact::CutEvent> events =
      interact::advance_scalpels(scalpels, model, sim, tools);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].report.cut_tets, whole.cut_tets);
  ASSERT_EQ(events[0].report.pieces.size(), 2u);
  for (size_t p = 0; p < 2; ++p)
    EXPECT_NEAR(events[0].report.pieces[p].volume_mm3, whole.pieces[p].volume_mm3,
                1e-6 * whole.pieces[p].volume_mm3);
}

TEST(Scalpel, ALoadOnTheCutNodesIsKeptWhole) {
  const Across s = across();
  auto model = std::make_shared<const Model>(test::tet_phantom());
  sim::Simulation sim = held();
  interact::ToolDriver tools;
  // A tool by vertex on a skin node the cut divides, pressing while the blade passes.
  int32_t on_cut = -1;
  double best = 1e9;
  for (int32_t i = 0; i < model->layers[0].node_count; ++i)
    if (!sim.fixed()[static_cast<size_t>(i)] && std::abs(model->X(i, 0) - s.x0) < best)
      best = std::abs(model->X(i, 0) - s.x0), on_cut = i;
  interact::Tool t;
  t.vertex = on_cut;
  t.force_mn = Eigen::Vector3d(0, 0, 50);
  t.radius_mm = 6.0;
  tools.tools = {t};
  tools.routing.routing = interact::Routing::kNone;
  tools.routing.touch = interact::Touch::kSkin;
  interact::ScalpelDriver scalpels = interact::make_scalpel_driver(std::vector{s.scalpel}, *model);
  int cuts = 0;
  for (int k = 0; k < 150; ++k) {
    interact::apply_tools(sim, tools);
    const Eigen::Vector3d before = sim.f_ext.colwise().sum();
    const auto events = interact::advance_scalpels(scalpels, model, sim, tools);
    cuts += static_cast<int>(events.size());
    ASSERT_LT((sim.f_ext.colwise().sum().transpose() - before).norm(), 1e-9 * 50) << k;
    interact::apply_tools(sim, tools);
    ASSERT_LT((sim.f_ext.colwise().sum().transpose() - t.force_mn).norm(), 1e-6 * 50) << k;
    ASSERT_EQ(sim::step(sim).unstable, sim::Instability::kNone) << "step " << k;
  }
  EXPECT_GT(cuts, 3);
  EXPECT_GT(model->node_count(), test::tet_phantom().node_count());
}

// A loop's live hands are in its tool driver (the one-organ loop's and every world body's):
// a cut carries the users' forces and the tip's load whole to the copies, and the grasper's hold
// to every copy of each node it held, as it carries a scene's tools.
TEST(Scalpel, TheLiveHandsAreCarriedThroughACutWithTheTools) {
  const Across s = across();
  auto model = std::make_shared<const Model>(test::tet_phantom());
  sim::Simulation sim = held();
  interact::ToolDriver tools;
  tools.routing.routing = interact::Routing::kNone;
  tools.routing.touch = interact::Touch::kSkin;
  // Free skin nodes nearest the blade's plane, on either side of it: what the cut divides.
  std::vector<int32_t> near_cut;
  for (int32_t i = 0; i < model->layers[0].node_count; ++i)
    if (!sim.fixed()[static_cast<size_t>(i)]) near_cut.push_back(i);
  std::sort(near_cut.begin(), near_cut.end(), [&](int32_t a, int32_t b) {
    return std::abs(model->X(a, 0) - s.x0) < std::abs(model->X(b, 0) - s.x0);
  });
  ASSERT_GE(near_cut.size(), 3U);
  const Eigen::Vector3d push(0, 0, 40), tip(0, 10, -20);
  tools.live_routes = {
      interact::load_at_node(*model, sim.x, near_cut[0], push, 6.0, tools.routing)};
  tools.tip = interact::load_at_node(*model, sim.x, near_cut[1], tip, 4.0, tools.routing);
  interact::close_jaws(sim, {.center_mm = sim.x.row(near_cut[2]).transpose(), .radius_mm = 5.0},
                       tools.hand, "grasper");
  const std::set<int32_t> held_before(tools.hand.nodes.begin(), tools.hand.nodes.end());
  ASSERT_FALSE(held_before.empty());
  interact::apply_tools(sim, tools);
  ASSERT_LT((sim.f_ext.colwise().sum().transpose() - push - tip).norm(), 1e-9 * 50);
  const auto per_node = [](const interact::ForceRoute& r) {
    std::map<int32_t, Eigen::Vector3d> m;
    for (size_t k = 0; k < r.nodes.size(); ++k)
      m[r.nodes[k]] = r.forces.row(static_cast<Eigen::Index>(k)).transpose();
    return m;
  };
  const std::map<int32_t, Eigen::Vector3d> live_before = per_node(tools.live_routes[0]),
                                           tip_before = per_node(tools.tip);

  std::vector<int32_t> origin;
  const model::CutReport r = interact::cut_now(
      model, sim, tools, s.scalpel.path, s.scalpel.depth_direction, s.scalpel.depth_mm, origin);
  ASSERT_GT(r.cut_tets, 0);
  ASSERT_GT(model->node_count(), test::tet_phantom().node_count());

  // The loads whole on the cut model's nodes.
  interact::apply_tools(sim, tools);
  EXPECT_LT((sim.f_ext.colwise().sum().transpose() - push - tip).norm(), 1e-6 * 50);
  // Each load on the copies of the nodes it was on, divided among them (a node's copies carry
  // its share; the cut renumbers the nodes, so a load left on the old numbers lands elsewhere).
  for (const auto& [route, was] :
       {std::pair{&tools.live_routes[0], live_before}, std::pair{&tools.tip, tip_before}}) {
    std::map<int32_t, Eigen::Vector3d> per_origin;
    for (size_t k = 0; k < route->nodes.size(); ++k) {
      const int32_t o = origin[static_cast<size_t>(route->nodes[k])];
      ASSERT_TRUE(was.count(o)) << "node " << route->nodes[k] << " came from " << o;
      per_origin.try_emplace(o, Eigen::Vector3d::Zero()).first->second +=
          route->forces.row(static_cast<Eigen::Index>(k)).transpose();
    }
    ASSERT_EQ(per_origin.size(), was.size());
    for (const auto& [o, f] : per_origin) EXPECT_LT((f - was.at(o)).norm(), 1e-9 * 50) << o;
  }
  // Every copy of a held node held, nothing else.
  std::set<int32_t> held_after(tools.hand.nodes.begin(), tools.hand.nodes.end());
  for (int32_t i = 0; i < model->node_count(); ++i)
    EXPECT_EQ(held_after.count(i), held_before.count(origin[static_cast<size_t>(i)])) << i;
  EXPECT_GT(held_after.size(), held_before.size()) << "the grasp was not on the cut";
  ASSERT_EQ(tools.hand.offsets.rows(), static_cast<Eigen::Index>(tools.hand.nodes.size()));
  interact::move_jaws(sim, sim.x.row(near_cut[2]).transpose() + Eigen::Vector3d(0, 0, 2),
                      tools.hand);
  for (int k = 0; k < 50; ++k) ASSERT_EQ(sim::step(sim).unstable, sim::Instability::kNone) << k;
}

// On an organ cut in two - its back held, its front free - a tool's load on the tissue is what
// the tissue pushes back with at rest (force conserved across the cut model), and the freed
// front piece, pushed and let go, comes to rest without its energy ever growing.
TEST(Scalpel, OnACutOrganTheLoadIsTheReactionAndAFreedPieceComesToRest) {
  const Model& m0 = test::tet_phantom();
  auto model = std::make_shared<const Model>(m0);
  sim::Material damped = test::kTetLiver;
  damped.mass_damping_per_s = 5.0;  // the scenes' critical damping is about 37/s on the phantom
  sim::Simulation sim = sim::make_simulation(
      m0, damped,
      {.integrator = sim::Integrator::kImplicitEuler, .dt_s = 0.01, .rest_speed_mm_per_s = 1e-3});
  sim::fix_nodes(sim, test::posterior_nodes(m0));
  const Eigen::Vector3d lo = m0.X.colwise().minCoeff(), hi = m0.X.colwise().maxCoeff();
  const double y0 = 0.5 * (lo.y() + hi.y()) + 0.37;
  interact::ToolDriver tools;
  tools.routing.routing = interact::Routing::kNone;
  tools.routing.touch = interact::Touch::kSkin;
  std::vector<int32_t> origin;
  const model::CutReport r = interact::cut_now(
      model, sim, tools,
      {Eigen::Vector3d(lo.x() - 5, y0, lo.z() - 5), Eigen::Vector3d(hi.x() + 5, y0, lo.z() - 5)},
      Eigen::Vector3d::UnitZ(), hi.z() - lo.z() + 10, origin);
  ASSERT_EQ(r.pieces.size(), 2u);
  const Model& m = *model;

  // A push on the held piece, beside the wound: at rest the tissue pushes back with all of it.
  int32_t node = -1;
  for (int32_t i = 0; i < m.layers[0].node_count; ++i)
    if (!sim.fixed()[static_cast<size_t>(i)] && m.X(i, 1) > y0 + 25 &&
        (node < 0 || m.X(i, 1) < m.X(node, 1)))
      node = i;
  ASSERT_GE(node, 0);
  interact::Tool push;
  push.vertex = node;
  push.force_mn = Eigen::Vector3d(0, 0, 40);
  push.radius_mm = 6.0;
  tools.tools = {push};
  const interact::ToolRun under_load = interact::run_tools(sim, tools, 200.0, true);
  ASSERT_TRUE(under_load.converged);
  const Eigen::Vector3d reaction = interact::tools_reaction(sim, tools);
  EXPECT_LT((reaction + push.force_mn).norm(), 0.01 * push.force_mn.norm())
      << "reaction " << reaction.transpose();

  // The free front piece pushed for 0.2 s, then let go.
  interact::ToolDriver none;
  sim::reset(sim);
  for (int32_t i = 0; i < m.layers[0].node_count; ++i)
    if (m.X(i, 1) < y0 - 3) sim.f_ext(i, 1) = -5.0;
  for (int k = 0; k < 20; ++k) ASSERT_EQ(sim::step(sim).unstable, sim::Instability::kNone);
  sim.f_ext.setZero();
  // The simulation's own watch fails a step whose total energy grows while no tool acts; its
  // motion's energy, strain turned into speed at first, dies away.
  double released = -1.0, later = 0.0;
  sim::RestStreak rest{.needed = sim::quiet_steps(sim)};
  bool at_rest = false;
  for (int k = 0; k < 20000 && !at_rest; ++k) {
    const sim::StepStats st = sim::step(sim);
    ASSERT_EQ(st.unstable, sim::Instability::kNone) << k;
    if (released < 0) released = st.kinetic_energy_j;
    if (k >= 100) later = std::max(later, st.kinetic_energy_j);
    at_rest = rest.update(st);
  }
  EXPECT_TRUE(at_rest) << "the freed piece did not come to rest";
  EXPECT_LT(later, 0.5 * released) << "its motion did not die away";
  EXPECT_EQ(sim::inverted_tets(m, sim.x), 0);
}

TEST(Scalpel, BadScalpelsAreNamed) {
  const Across s = across();
  const auto problem = [&](auto change) {
    interact::Scalpel sc = s.scalpel;
    change(sc);
    const auto p = interact::scalpel_problem(sc);
    return p ? p->first : std::string();
  };
  EXPECT_EQ(problem([](interact::Scalpel&) {}), "");
  EXPECT_EQ(problem([](interact::Scalpel& c) { c.path.resize(1); }), "path");
  EXPECT_EQ(problem([](interact::Scalpel& c) { c.path[1] = c.path[0]; }), "path");
  EXPECT_EQ(problem([](interact::Scalpel& c) { c.path[1].x() = NAN; }), "path[1]");
  EXPECT_EQ(problem([](interact::Scalpel& c) { c.depth_mm = 0; }), "depth_mm");
  EXPECT_EQ(problem([](interact::Scalpel& c) { c.depth_direction = Eigen::Vector3d::UnitY(); }),
            "direction");
  EXPECT_EQ(problem([](interact::Scalpel& c) { c.end_s = c.start_s; }), "end_s");
  EXPECT_THROW(interact::make_scalpel_driver(std::vector{interact::Scalpel{}}, test::tet_phantom()),
               Error);
}

}  // namespace
