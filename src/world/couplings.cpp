// Contact and attachments as implicit springs: a node that entered a skin (or a tie's node) is
// held at its point of the other skin by a zero-length spring inside its own body's implicit
// step (sim::set_contact_stiffness: stiffness k in the system, k (T - X) in f_ext), where a
// spring stiff enough to hold 2 N within half a millimetre on nodes of a few milligrams is
// stable; the spring's other end, on the other body's triangle, gets the equal and opposite
// force at the next step. What one body receives the other gives: each step's spring forces
// are handed over whole, one step later (docs/world.md: why not both in one step, and why not
// projections after the solve).
#include <algorithm>
#include <cmath>

#include "lamina/sim/contact_springs.h"
#include "world_work.h"

namespace lamina::world::detail {
namespace {

Eigen::Vector3d point_on(const Body& b, const std::array<int32_t, 3>& corners,
                         const Eigen::Vector3d& weights) {
  Eigen::Vector3d q = Eigen::Vector3d::Zero();
  for (int a = 0; a < 3; ++a) q += weights[a] * b.sim.x.row(corners[a]).transpose();
  return q;
}

const std::vector<double>& areas_of(WorldWork& w, size_t slot, const Model& model) {
  if (w.node_area.size() <= slot) w.node_area.resize(slot + 1);
  std::vector<double>& a = w.node_area[slot];
  if (a.size() != static_cast<size_t>(model.node_count())) a = skin_node_area(model);
  return a;
}

void add_force(Body& b, int32_t node, const Eigen::Vector3d& f) {
  b.sim.f_ext.row(node) += f.transpose();
  b.tools.loads.nodes.push_back(node);  // cleared with the tools' loads next step
}

}  // namespace

void begin_couplings(World& world, WorldStepStats& out) {
  WorldWork& w = world.work();
  const size_t slots = world.bodies.size();
  w.spring_nodes.resize(slots);
  w.spring_k.resize(slots);
  w.pending.resize(slots);
  w.arriving.resize(slots);
  w.had_springs.resize(slots, 0);
  w.pushed.resize(slots);
  w.couplings.clear();
  for (size_t s = 0; s < slots; ++s) {
    w.spring_nodes[s].clear();
    w.spring_k[s].clear();
    std::swap(w.pending[s], w.arriving[s]);  // last step's other ends arrive now
    w.pending[s].clear();
  }
  // Contacts at the start of the step.
  if (world.contact.enabled) {
    find_contacts(world, /*measure_rest=*/false);
    for (const Contact& c : w.contacts) {
      const Body& nb = world.bodies[static_cast<size_t>(c.body)].body;
      const Body& ob = world.bodies[static_cast<size_t>(c.other)].body;
      const double allowance = nb.rest_overlap_mm[static_cast<size_t>(c.node)];
      const double area =
          areas_of(w, static_cast<size_t>(c.body), *nb.model)[static_cast<size_t>(c.node)];
      w.couplings.push_back({.body = c.body,
                             .node = c.node,
                             .other = c.other,
                             .corners = c.corners,
                             .weights = c.weights,
                             .target = point_on(ob, c.corners, c.weights) - allowance * c.normal,
                             .stiffness_n_per_m = world.contact.stiffness_kpa_per_mm * area,
                             .tie = nullptr,
                             .normal = c.normal,
                             .allowance_mm = allowance});
    }
  } else {
    w.contacts.clear();
  }
  // Ties: each node pulled to its length from its point.
  for (AttachmentSlot& slot : world.attachments) {
    if (!slot.alive) continue;
    for (Tie& t : slot.attachment.ties) {
      if (!t.active()) continue;
      const Body& nb = world.bodies[static_cast<size_t>(t.node_body)].body;
      const Body& sb = world.bodies[static_cast<size_t>(t.surface_body)].body;
      const Eigen::Vector3d q = point_on(sb, t.corners, t.weights);
      const Eigen::Vector3d d = nb.sim.x.row(t.node).transpose() - q;
      const double len = d.norm();
      w.couplings.push_back({.body = t.node_body,
                             .node = t.node,
                             .other = t.surface_body,
                             .corners = t.corners,
                             .weights = t.weights,
                             .target = len > 1e-9 ? Eigen::Vector3d(q + t.rest_mm * d / len) : q,
                             .stiffness_n_per_m = t.stiffness_n_per_m,
                             .tie = &t});
    }
  }
  for (const Coupling& c : w.couplings) {
    Body& b = world.bodies[static_cast<size_t>(c.body)].body;
    w.spring_nodes[static_cast<size_t>(c.body)].push_back(c.node);
    w.spring_k[static_cast<size_t>(c.body)].push_back(c.stiffness_n_per_m);
    add_force(b, c.node, c.stiffness_n_per_m * (c.target - b.model->X.row(c.node).transpose()));
  }
  for (size_t s = 0; s < slots; ++s) {
    if (!world.bodies[s].alive) continue;
    Body& b = world.bodies[s].body;
    BodyStepStats& st = out.bodies[static_cast<size_t>(w.row_of_slot[s])];
    for (const PendingForce& p : w.arriving[s]) {
      add_force(b, p.node, p.force_mn);
      (p.contact ? st.contact_force_mn : st.attachment_force_mn) += p.force_mn;
    }
    // Last step's springs go where none are needed now.
    const bool springs = !w.spring_nodes[s].empty();
    if (springs || w.had_springs[s])
      sim::set_contact_stiffness(b.sim, w.spring_nodes[s], w.spring_k[s]);
    w.had_springs[s] = springs ? 1 : 0;
  }
}

void end_couplings(World& world, WorldStepStats& out) {
  WorldWork& w = world.work();
  for (size_t s = 0; s < world.bodies.size(); ++s) {
    std::vector<uint8_t>& pushed = w.pushed[s];
    if (!world.bodies[s].alive) continue;
    pushed.assign(static_cast<size_t>(world.bodies[s].body.model->node_count()), 0);
  }
  for (const Coupling& c : w.couplings) {
    const Body& nb = world.bodies[static_cast<size_t>(c.body)].body;
    const Body& ob = world.bodies[static_cast<size_t>(c.other)].body;
    const Eigen::Vector3d p = nb.sim.x.row(c.node).transpose();
    const Eigen::Vector3d f = -c.stiffness_n_per_m * (p - c.target);  // on the node, mN
    BodyStepStats& st = out.bodies[static_cast<size_t>(w.row_of_slot[static_cast<size_t>(c.body)])];
    const bool contact = c.tie == nullptr;
    (contact ? st.contact_force_mn : st.attachment_force_mn) += f;
    for (int a = 0; a < 3; ++a)
      if (c.weights[a] != 0.0)
        w.pending[static_cast<size_t>(c.other)].push_back(
            {.node = c.corners[a], .force_mn = -c.weights[a] * f, .contact = contact});
    const Eigen::Vector3d q = point_on(ob, c.corners, c.weights);
    if (contact) {
      if (c.body == c.other)
        ++st.self_contacts;
      else
        ++st.contacts;
      const double depth = -(p - q).dot(c.normal) - c.allowance_mm;
      st.max_penetration_mm = std::max(st.max_penetration_mm, depth);
      if (f.dot(c.normal) > 0.0)
        w.pushed[static_cast<size_t>(c.body)][static_cast<size_t>(c.node)] = 1;
    } else {
      const Eigen::Vector3d d = p - q;
      const double len = d.norm();
      Tie& t = *c.tie;
      t.force_mn = len > 1e-9 ? -f.dot(d / len) : f.norm();  // > 0: pulling the ends together
      if (t.force_mn > t.strength_mn) {
        t.torn = true;
        ++out.ties_torn;
      }
    }
  }
}

}  // namespace lamina::world::detail
