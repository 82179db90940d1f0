// A running simulation cut: the model divided, and everything that names its nodes - the
// simulation's state, the tools' loads and grasps - moved to the copies.
#include <algorithm>

#include "lamina/interact/scalpel.h"
#include "lamina/sim/carry_over.h"

namespace lamina::interact {
namespace {

// Each old node's copies (CSR over the old nodes).
struct Copies {
  std::vector<int32_t> first, of;
};

Copies copies_of(const std::vector<int32_t>& origin, int32_t old_nodes) {
  Copies c;
  c.first.assign(static_cast<size_t>(old_nodes) + 1, 0);
  for (int32_t o : origin) ++c.first[static_cast<size_t>(o) + 1];
  for (size_t k = 0; k < static_cast<size_t>(old_nodes); ++k) c.first[k + 1] += c.first[k];
  c.of.resize(origin.size());
  std::vector<int32_t> fill(c.first.begin(), c.first.end() - 1);
  for (size_t i = 0; i < origin.size(); ++i)
    c.of[static_cast<size_t>(fill[static_cast<size_t>(origin[i])]++)] = static_cast<int32_t>(i);
  return c;
}

std::vector<int32_t> every_copy(const Copies& c, const std::vector<int32_t>& nodes) {
  std::vector<int32_t> out;
  out.reserve(nodes.size());
  for (int32_t v : nodes)
    for (int32_t k = c.first[v]; k < c.first[v + 1]; ++k) out.push_back(c.of[k]);
  return out;
}

}  // namespace

void carry_tools(const Model& before, const Model& cut, const std::vector<int32_t>& origin,
                 ToolDriver& driver) {
  const Copies c = copies_of(origin, before.node_count());
  const auto share = [&](int32_t i) { return model::copy_share(before, cut, origin, i); };

  // A tool's load on a node is divided among its copies as its mass is (the total is kept); a
  // tool by vertex touches the node's first copy (it is on the skin, as the node was).
  for (Tool& t : driver.tools)
    if (!t.by_point) t.vertex = c.of[c.first[t.vertex]];
  const auto carry_route = [&](ForceRoute& r) {
    if (r.contact_node >= 0) r.contact_node = c.of[c.first[r.contact_node]];
    for (Crossing& x : r.crossings) x.node = c.of[c.first[x.node]];
    std::vector<int32_t> nodes;
    Eigen::MatrixX3d forces(0, 3);
    std::vector<Eigen::RowVector3d> rows;
    for (size_t k = 0; k < r.nodes.size(); ++k)
      for (int32_t q = c.first[r.nodes[k]]; q < c.first[r.nodes[k] + 1]; ++q) {
        nodes.push_back(c.of[q]);
        rows.push_back(r.forces.row(static_cast<Eigen::Index>(k)) * share(c.of[q]));
      }
    forces.resize(static_cast<Eigen::Index>(rows.size()), 3);
    for (size_t k = 0; k < rows.size(); ++k) forces.row(static_cast<Eigen::Index>(k)) = rows[k];
    // Copies are numbered after their node, so the list stays ascending.
    r.nodes = std::move(nodes);
    r.forces = std::move(forces);
  };
  // A grasp holds every copy of a node it held, at that node's offset from the jaws.
  const auto carry_grasp = [&](Grasp& g) {
    if (g.nodes.empty()) return;
    Eigen::MatrixX3d offsets(0, 3), targets(0, 3);
    std::vector<int32_t> nodes;
    std::vector<Eigen::Index> from;
    for (size_t k = 0; k < g.nodes.size(); ++k)
      for (int32_t q = c.first[g.nodes[k]]; q < c.first[g.nodes[k] + 1]; ++q)
        nodes.push_back(c.of[q]), from.push_back(static_cast<Eigen::Index>(k));
    offsets.resize(static_cast<Eigen::Index>(nodes.size()), 3);
    targets.resize(offsets.rows(), 3);
    for (size_t k = 0; k < from.size(); ++k) {
      offsets.row(static_cast<Eigen::Index>(k)) = g.offsets.row(from[k]);
      if (g.targets.rows() == g.offsets.rows())
        targets.row(static_cast<Eigen::Index>(k)) = g.targets.row(from[k]);
    }
    g.nodes = std::move(nodes);
    g.offsets = std::move(offsets);
    g.targets = std::move(targets);
  };
  for (ForceRoute& r : driver.routes) carry_route(r);
  for (ForceRoute& r : driver.live_routes) carry_route(r);
  carry_route(driver.tip);
  driver.touched = every_copy(c, driver.touched);
  driver.loads.nodes = every_copy(c, driver.loads.nodes);
  for (Grasp& g : driver.grasps) carry_grasp(g);
  carry_grasp(driver.hand);
  if (driver.held_forces.rows() == before.node_count()) {
    Eigen::MatrixX3d held(cut.node_count(), 3);
    for (int32_t i = 0; i < cut.node_count(); ++i)
      held.row(i) = driver.held_forces.row(origin[static_cast<size_t>(i)]) * share(i);
    driver.held_forces = std::move(held);
  }
}

model::CutReport cut_simulation(std::shared_ptr<const Model>& model, sim::Simulation& sim,
                                ToolDriver& driver, const model::Blade& rest_blade,
                                std::vector<int32_t>& origin, const model::CutOptions& options) {
  auto cut = std::make_shared<Model>();
  model::CutReport report;
  model::cut_tetrahedra(*model, model->X, rest_blade, *cut, origin, report, options);
  if (!report.changed()) {
    origin.resize(static_cast<size_t>(model->node_count()));
    for (size_t i = 0; i < origin.size(); ++i) origin[i] = static_cast<int32_t>(i);
    return report;
  }
  carry_tools(*model, *cut, origin, driver);
  sim = sim::carry_over(sim, *cut, origin);
  model = std::move(cut);
  return report;
}

}  // namespace lamina::interact
