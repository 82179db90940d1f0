// The cuts a world has taken, taken back one at a time or all at once (cut_history.h).
#include "lamina/world/cut_history.h"

#include <utility>

#include "lamina/interact/grasp.h"

namespace lamina::world {
namespace {

// Whether a simulation stepping with (m, o) would change if given (n, p): sim::Material and
// sim::SolverOptions have no ==, so field by field (a field added to either belongs here too:
// the sizes below catch it).
static_assert(sizeof(sim::Material) == 96, "a new field of sim::Material: compare it here");
static_assert(sizeof(sim::SolverOptions) == 56, "a new field of sim::SolverOptions: here too");
bool same_parameters(const sim::Material& m, const sim::SolverOptions& o, const sim::Material& n,
                     const sim::SolverOptions& p) {
  return m.stiffness_n_per_m == n.stiffness_n_per_m && m.damping_kg_per_s == n.damping_kg_per_s &&
         m.mass_damping_per_s == n.mass_damping_per_s && m.node_mass_kg == n.node_mass_kg &&
         m.anchor_stiffness_n_per_m == n.anchor_stiffness_n_per_m &&
         m.volume_stiffness_kpa == n.volume_stiffness_kpa &&
         m.young_modulus_kpa == n.young_modulus_kpa && m.poisson_ratio == n.poisson_ratio &&
         m.tet_elasticity == n.tet_elasticity && m.tet_model == n.tet_model &&
         m.gravity_mm_per_s2 == n.gravity_mm_per_s2 && o.integrator == p.integrator &&
         o.dt_s == p.dt_s && o.rest_speed_mm_per_s == p.rest_speed_mm_per_s &&
         o.max_steps == p.max_steps && o.mode == p.mode &&
         o.cg_max_iterations == p.cg_max_iterations && o.cg_tolerance == p.cg_tolerance &&
         o.preconditioner == p.preconditioner && o.projective_iterations == p.projective_iterations;
}

}  // namespace

std::vector<std::vector<uint8_t>> divided_flags(const World& world) {
  std::vector<std::vector<uint8_t>> out(world.attachments.size());
  for (size_t a = 0; a < world.attachments.size(); ++a)
    for (const Tie& t : world.attachments[a].attachment.ties) out[a].push_back(t.divided ? 1 : 0);
  return out;
}

std::vector<std::vector<uint8_t>> divided_since(const World& world,
                                                const std::vector<std::vector<uint8_t>>& before) {
  std::vector<std::vector<uint8_t>> now = divided_flags(world);
  for (size_t a = 0; a < now.size(); ++a)
    for (size_t k = 0; k < now[a].size(); ++k)
      now[a][k] = now[a][k] && !(a < before.size() && k < before[a].size() && before[a][k]);
  return now;
}

void push_cut(CutHistory& history, CutUndo cut) {
  history.undo.push_back(std::move(cut));
  if (history.undo.size() > CutHistory::kDepth) {  // the oldest kept for a reset only
    fold_before(history.oldest, history.undo.front().before);
    history.undo.erase(history.undo.begin());
  }
}

int32_t undo_cut(World& world, CutUndo& cut) {
  // What each body keeps of now: its clock and its parameters (a material set since the cut is
  // the one a panel shows).
  struct Now {
    BodyId id;
    double time_s;
    int64_t steps;
    sim::Material material;
    sim::SolverOptions solver;
    interact::RoutingOptions routing;
  };
  std::vector<Now> now;
  for (const BodyBefore& k : cut.before.bodies) {
    if (!is_valid(world, k.id)) continue;
    const Body& b = body(world, k.id);
    now.push_back(
        {k.id, b.sim.time_s, b.sim.steps, b.sim.material(), b.sim.options(), b.tools.routing});
  }
  // The ties go back to the bodies' numbering of then (a cut renumbers them in place: the lists
  // stay aligned), each as it is now, but those the stroke divided, joined again.
  std::vector<std::vector<Tie>> ties_now;
  for (const AttachmentSlot& a : world.attachments) ties_now.push_back(a.attachment.ties);
  put_back(world, cut.before);
  int32_t joined = 0;
  for (size_t a = 0; a < world.attachments.size(); ++a) {
    std::vector<Tie>& ties = world.attachments[a].attachment.ties;
    if (ties.size() != ties_now[a].size()) continue;  // not renumbered from these: left as kept
    for (size_t k = 0; k < ties.size(); ++k) {
      const bool by_stroke = a < cut.stroke_divided.size() && k < cut.stroke_divided[a].size() &&
                             cut.stroke_divided[a][k];
      ties[k].divided = ties_now[a][k].divided && !by_stroke;
      joined += by_stroke && ties_now[a][k].divided;
      ties[k].torn = ties_now[a][k].torn;
      ties[k].force_mn = ties_now[a][k].force_mn;
    }
  }
  for (const Now& n : now) {
    Body& b = body(world, n.id);
    if (!b.tools.hand.nodes.empty()) {  // a grasp of then, which the jaws no longer hold
      interact::open_jaws(b.sim, b.tools.hand);
      b.tools.hand = {};
    }
    b.sim.time_s = n.time_s;
    b.sim.steps = n.steps;
    // Only when they differ: setting them makes the solver's hierarchy again.
    if (!same_parameters(b.sim.material(), b.sim.options(), n.material, n.solver))
      sim::set_parameters(b.sim, n.material, n.solver);
    b.tools.routing = n.routing;
  }
  cut = CutUndo{};
  return joined;
}

void put_back_all(World& world, CutHistory& history, std::vector<int32_t>* slots) {
  for (CutUndo& u : history.undo) fold_before(history.oldest, u.before);  // the earliest wins
  history.undo.clear();
  if (slots)
    for (const BodyBefore& k : history.oldest.bodies) slots->push_back(k.id.index);
  put_back(world, history.oldest);
}

}  // namespace lamina::world
