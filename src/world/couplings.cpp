// Contact and attachments as implicit springs that meet halfway: a node that entered a skin (or
// a tie's node) and the point of the other skin it is coupled to are each pulled towards the
// middle of where they should be, by zero-length springs inside their own bodies' implicit
// steps (sim::set_contact_stiffness: stiffness k in the system, k (T - X) in f_ext), where a
// spring stiff enough to hold 2 N within half a millimetre on nodes of a few milligrams is
// stable. Neither side's force is explicit in the other: each body sees the meeting point fixed
// for its step, and the next step takes a new one from where both ended (a block-Jacobi sweep,
// which only contracts the gap). Pulled to the middle of their current positions, the two
// springs' forces are equal and opposite whenever the bodies are at rest (docs/world.md).
#include <algorithm>
#include <cmath>

#include "lamina/sim/contact_springs.h"
#include "world_work.h"

namespace lamina::world::detail {
namespace {

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

// The coupling of node p (body nb) to the skin point of ob with `weights` on `corners`, which
// should end at p - offset: both pulled to the middle of p and (that point + offset).
Coupling halfway(const Body& nb, const Body& ob, int32_t node,
                 const std::array<int32_t, 3>& corners, const Eigen::Vector3d& weights,
                 const Eigen::Vector3d& offset) {
  Coupling c;
  c.node = node;
  c.corners = corners;
  c.weights = weights;
  const Eigen::Vector3d p = nb.sim.x.row(node).transpose();
  const Eigen::Vector3d q = point_on(ob, corners, weights);
  const Eigen::Vector3d shift = 0.5 * (p - offset - q);  // how far the skin point moves
  c.target = p - shift;                                  // and the node, the other way
  for (int a = 0; a < 3; ++a) c.corner_targets[a] = ob.sim.x.row(corners[a]).transpose() + shift;
  return c;
}

}  // namespace

void begin_couplings(World& world) {
  WorldWork& w = world.work();
  const size_t slots = world.bodies.size();
  w.spring_nodes.resize(slots);
  w.spring_k.resize(slots);
  w.had_springs.resize(slots, 0);
  w.pushed.resize(slots);
  w.couplings.clear();
  for (size_t s = 0; s < slots; ++s) {
    w.spring_nodes[s].clear();
    w.spring_k[s].clear();
  }
  // Contacts at the start of the step: the node should sit at its rest overlap under the skin.
  if (world.contact.enabled) {
    find_contacts(world, /*measure_rest=*/false);
    for (const Contact& ct : w.contacts) {
      const Body& nb = world.bodies[static_cast<size_t>(ct.body)].body;
      const Body& ob = world.bodies[static_cast<size_t>(ct.other)].body;
      const double allowance = nb.rest_overlap_mm[static_cast<size_t>(ct.node)];
      const double area =
          areas_of(w, static_cast<size_t>(ct.body), *nb.model)[static_cast<size_t>(ct.node)];
      Coupling c = halfway(nb, ob, ct.node, ct.corners, ct.weights, allowance * ct.normal);
      c.body = ct.body;
      c.other = ct.other;
      c.stiffness_n_per_m = world.contact.stiffness_kpa_per_mm * area;
      c.normal = ct.normal;
      c.allowance_mm = allowance;
      w.couplings.push_back(c);
    }
  } else {
    w.contacts.clear();
  }
  // Ties: the node should sit its length from its point, along where it is now.
  for (AttachmentSlot& slot : world.attachments) {
    if (!slot.alive) continue;
    for (Tie& t : slot.attachment.ties) {
      if (!t.active()) continue;
      const Body& nb = world.bodies[static_cast<size_t>(t.node_body)].body;
      const Body& sb = world.bodies[static_cast<size_t>(t.surface_body)].body;
      const Eigen::Vector3d d =
          nb.sim.x.row(t.node).transpose() - point_on(sb, t.corners, t.weights);
      const double len = d.norm();
      const Eigen::Vector3d offset =
          len > 1e-9 ? Eigen::Vector3d(t.rest_mm * d / len) : Eigen::Vector3d::Zero();
      Coupling c = halfway(nb, sb, t.node, t.corners, t.weights, offset);
      c.body = t.node_body;
      c.other = t.surface_body;
      c.stiffness_n_per_m = t.stiffness_n_per_m;
      c.tie = &t;
      w.couplings.push_back(c);
    }
  }
  for (const Coupling& c : w.couplings) {
    Body& nb = world.bodies[static_cast<size_t>(c.body)].body;
    Body& ob = world.bodies[static_cast<size_t>(c.other)].body;
    const double k = c.stiffness_n_per_m;
    w.spring_nodes[static_cast<size_t>(c.body)].push_back(c.node);
    w.spring_k[static_cast<size_t>(c.body)].push_back(k);
    add_force(nb, c.node, k * (c.target - nb.model->X.row(c.node).transpose()));
    for (int a = 0; a < 3; ++a) {
      if (c.weights[a] == 0.0) continue;
      const double ka = k * c.weights[a];
      w.spring_nodes[static_cast<size_t>(c.other)].push_back(c.corners[a]);
      w.spring_k[static_cast<size_t>(c.other)].push_back(ka);
      add_force(ob, c.corners[a],
                ka * (c.corner_targets[a] - ob.model->X.row(c.corners[a]).transpose()));
    }
  }
  for (size_t s = 0; s < slots; ++s) {
    if (!world.bodies[s].alive) continue;
    // Last step's springs go where none are needed now.
    const bool springs = !w.spring_nodes[s].empty();
    if (springs || w.had_springs[s])
      sim::set_contact_stiffness(world.bodies[s].body.sim, w.spring_nodes[s], w.spring_k[s]);
    w.had_springs[s] = springs ? 1 : 0;
  }
}

void end_couplings(World& world, WorldStepStats& out) {
  WorldWork& w = world.work();
  for (size_t s = 0; s < world.bodies.size(); ++s)
    if (world.bodies[s].alive)
      w.pushed[s].assign(static_cast<size_t>(world.bodies[s].body.model->node_count()), 0);
  for (const Coupling& c : w.couplings) {
    const Body& nb = world.bodies[static_cast<size_t>(c.body)].body;
    const Body& ob = world.bodies[static_cast<size_t>(c.other)].body;
    const Eigen::Vector3d p = nb.sim.x.row(c.node).transpose();
    const Eigen::Vector3d f = -c.stiffness_n_per_m * (p - c.target);  // on the node, mN
    Eigen::Vector3d g = Eigen::Vector3d::Zero();                      // on the skin's corners
    for (int a = 0; a < 3; ++a)
      g -= c.stiffness_n_per_m * c.weights[a] *
           (ob.sim.x.row(c.corners[a]).transpose() - c.corner_targets[a]);
    BodyStepStats& sn = out.bodies[static_cast<size_t>(w.row_of_slot[static_cast<size_t>(c.body)])];
    BodyStepStats& so =
        out.bodies[static_cast<size_t>(w.row_of_slot[static_cast<size_t>(c.other)])];
    const bool contact = c.tie == nullptr;
    (contact ? sn.contact_force_mn : sn.attachment_force_mn) += f;
    (contact ? so.contact_force_mn : so.attachment_force_mn) += g;
    const Eigen::Vector3d q = point_on(ob, c.corners, c.weights);
    if (contact) {
      if (c.body == c.other)
        ++sn.self_contacts;
      else
        ++sn.contacts;
      sn.max_penetration_mm =
          std::max(sn.max_penetration_mm, -(p - q).dot(c.normal) - c.allowance_mm);
      if (f.dot(c.normal) > 0.0)  // it pushed: it stays in contact within the margin
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
