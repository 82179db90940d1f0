#include "lamina/interact/grasp.h"

#include <fmt/format.h>

#include <cmath>

#include "lamina/core/error.h"

namespace lamina::interact {

void close_jaws(sim::Simulation& s, const Jaws& jaws, Grasp& grasp, const std::string& what) {
  if (!(jaws.radius_mm > 0.0 && std::isfinite(jaws.radius_mm)))
    throw invalid_input(what + ".radius_mm", fmt::format("must be > 0 mm, got {}", jaws.radius_mm));
  if (!jaws.center_mm.allFinite()) throw invalid_input(what, "the jaws' position is not finite");
  const Model& m = s.model();
  std::vector<int32_t> nodes;
  const double r2 = jaws.radius_mm * jaws.radius_mm;
  for (int32_t i = 0; i < m.layers[0].node_count; ++i)
    if (!s.fixed()[i] && (s.x.row(i).transpose() - jaws.center_mm).squaredNorm() <= r2)
      nodes.push_back(i);
  if (nodes.empty())
    throw invalid_input(what, fmt::format("nothing under the jaws: no free skin node within {} mm "
                                          "of [{:.2f}, {:.2f}, {:.2f}] (move them onto the skin "
                                          "or widen radius_mm)",
                                          jaws.radius_mm, jaws.center_mm.x(), jaws.center_mm.y(),
                                          jaws.center_mm.z()));
  grasp.nodes = std::move(nodes);
  grasp.closed_at_mm = jaws.center_mm;
  const auto n = static_cast<Eigen::Index>(grasp.nodes.size());
  grasp.offsets.resize(n, 3);
  grasp.targets.resize(n, 3);
  for (Eigen::Index k = 0; k < n; ++k) {
    grasp.targets.row(k) = s.x.row(grasp.nodes[static_cast<size_t>(k)]);
    grasp.offsets.row(k) = grasp.targets.row(k) - jaws.center_mm.transpose();
  }
  sim::hold_nodes(s, grasp.nodes, grasp.targets);
}

bool anything_under_jaws(const Model& m, const Eigen::MatrixX3d& x, const Jaws& jaws,
                         const std::vector<uint8_t>* fixed) {
  const double r2 = jaws.radius_mm * jaws.radius_mm;
  if (fixed != nullptr && fixed->size() != static_cast<size_t>(m.node_count())) fixed = nullptr;
  for (int32_t i = 0; i < m.layers[0].node_count; ++i)
    if ((x.row(i).transpose() - jaws.center_mm).squaredNorm() <= r2 &&
        (fixed == nullptr || (*fixed)[static_cast<size_t>(i)] == 0))
      return true;
  return false;
}

void move_jaws(sim::Simulation& s, const Eigen::Vector3d& center_mm, Grasp& grasp) {
  if (grasp.nodes.empty()) return;
  grasp.targets = grasp.offsets.rowwise() + center_mm.transpose();
  sim::hold_nodes(s, grasp.nodes, grasp.targets);
}

void open_jaws(sim::Simulation& s, Grasp& grasp) {
  if (!grasp.nodes.empty()) sim::release_nodes(s, grasp.nodes);
  grasp.nodes.clear();
}

Eigen::Vector3d grasp_reaction(const sim::Simulation& s, const Grasp& grasp) {
  return grasp.nodes.empty() ? Eigen::Vector3d::Zero() : sim::internal_force_on(s, grasp.nodes);
}

}  // namespace lamina::interact
