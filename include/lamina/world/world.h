#pragma once
/// \file
/// A world of bodies, in the manner of Box2D v3's b2World: plain definitions, handles that say
/// when they are stale, and one step(). A world owns its bodies (each an organ: its model, its
/// simulation and its tools), the attachments between them (connective tissue: ties that tear
/// and that a blade divides) and the contact between them and within each (docs/world.md).
/// One organ is a world of one body, and steps exactly as its simulation does on its own.
///
/// One step runs named, timed stages (WorldProfile): each body's tools; contact and attachments
/// (a skin node found inside another body's skin, or its own away from itself, and each tie's
/// node, coupled to its point of the other skin: both pulled to meet halfway by springs inside
/// their own bodies' implicit steps); each body's solve (its own sim::step); then the springs'
/// forces measured. Springs inside both implicit steps rather than a penalty force before them
/// or a projection after them: a penalty stiff enough to hold 2 N within 0.5 mm on nodes of a
/// few milligrams is far beyond an explicit force's stability at 1 ms, and the tissue threw a
/// projection back every step (docs/world.md has the measurements).
/// Units: mm, kg, s; forces mN.

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "lamina/interact/tools.h"
#include "lamina/model/model.h"
#include "lamina/sim/simulation.h"
#include "lamina/world/attachment.h"
#include "lamina/world/body_contact.h"

namespace lamina::world {

namespace detail {
struct WorldWork;  // world_work.h: the step's reusable buffers, private to module world
}

/// A body's handle: its slot and the slot's generation. Stale once the body is destroyed (the
/// slot's generation moves on): every call refuses it instead of reaching another body.
struct BodyId {
  int32_t index = -1;
  uint32_t generation = 0;
  friend bool operator==(const BodyId&, const BodyId&) = default;
};

/// An attachment's handle, stale once it is destroyed.
struct AttachmentId {
  int32_t index = -1;
  uint32_t generation = 0;
  friend bool operator==(const AttachmentId&, const AttachmentId&) = default;
};

/// What a body is made of. The model is shared so that its address stays put: the simulation
/// refers to it.
struct BodyDef {
  std::string name;  ///< names the body in messages and reports; unique in a world
  std::shared_ptr<const Model> model{};  ///< non-null, with the simulation made on it
  sim::Simulation simulation{};          ///< made with sim::make_simulation(*model, ...)
  interact::ToolDriver tools{};          ///< this body's tools (their times on the world's clock)
};

/// A body in the world.
struct Body {
  std::string name;
  std::shared_ptr<const Model> model;
  sim::Simulation sim;
  interact::ToolDriver tools;
  /// Counts the changes of this body's nodes (a cut): what a caller kept of an older
  /// generation (a node number, a picked point) must be taken again.
  uint32_t topology = 0;
  /// Per node: how deep its skin node lay inside another body (or itself) at rest, mm. Contact
  /// holds a node at that depth rather than pushing it out: two organs segmented side by side
  /// meet at their voxels' faces, and remeshing moves each skin a fraction of a voxel either way.
  std::vector<double> rest_overlap_mm;
};

/// A slot of the world's bodies: the body, if alive, and the slot's generation.
struct BodySlot {
  Body body;
  uint32_t generation = 1;
  bool alive = false;
};

/// Contact, the world's: between bodies and within each one.
struct ContactOptions {
  bool enabled = true;
  /// A body's skin nodes against its own skin, away from themselves: folded tissue meeting
  /// itself (a retracted lobe).
  bool self_contact = true;
  /// Deepest a node is looked for inside a skin, mm: deeper, it is taken as being on the other
  /// side of a thin part rather than pushed through.
  double reach_mm = 4.0;
  /// The contact's stiffness per unit area of skin, kPa/mm: a node that entered a skin is held
  /// at it by a spring of this times its skin area (2 N over 400 mm^2 enter by 0.25 mm).
  double stiffness_kpa_per_mm = 20.0;
  /// A node its contact pushed out last step stays in contact until it is this far outside
  /// the skin, mm: contact lets go only when it would pull (no chatter of a pressed node
  /// coming in and out of contact every other step).
  double margin_mm = 0.5;
  /// Self-contact ignores the triangles within this distance of the node at rest, mm (its own
  /// neighbourhood); 0: three of the skin's mean edge lengths, and at least reach_mm + 2 mm
  /// (the near lists' slack).
  double self_exclusion_mm = 0.0;
  /// Two bodies (or a body and itself) that overlap by more than this at rest are refused:
  /// a scene placing one organ inside another, mm.
  double rest_overlap_tolerance_mm = 3.0;
};

/// Where a world step's time went, microseconds.
struct WorldProfile {
  double tools_us = 0.0;    ///< every body's tools
  double solve_us = 0.0;    ///< every body's sim::step
  double contact_us = 0.0;  ///< contact and ties: the search, the springs set and measured
};

/// What one body's part of a world step measured.
struct BodyStepStats {
  sim::StepStats sim;  ///< its own step's (the contact's correction is not in them)
  /// Deepest a skin node of this body in contact lies inside the other skin beyond its rest
  /// overlap after the step, mm.
  double max_penetration_mm = 0.0;
  /// The contact force on this body this step, mN: its couplings' springs' (on its nodes and on
  /// its triangles' corners).
  Eigen::Vector3d contact_force_mn = Eigen::Vector3d::Zero();
  /// The attachments' force on this body this step, mN.
  Eigen::Vector3d attachment_force_mn = Eigen::Vector3d::Zero();
  int32_t contacts = 0;       ///< skin nodes of this body inside another body
  int32_t self_contacts = 0;  ///< skin nodes of this body inside its own skin
};

/// What a world step measured.
struct WorldStepStats {
  std::vector<BodyStepStats> bodies;  ///< per live body, in slot order
  WorldProfile profile;
  double step_us = 0.0;
  int32_t ties_torn = 0;  ///< ties that tore this step
  /// Every body at rest (sim::at_rest) and no tie torn.
  bool converged = false;
  /// The first body's instability, if any (its name in unstable_body).
  sim::Instability unstable = sim::Instability::kNone;
  std::string unstable_body;
};

/// The world. Read its bodies and attachments freely; change them through the functions below.
class World {
 public:
  World();
  ~World();
  World(World&&) noexcept;
  World& operator=(World&&) noexcept;
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  std::vector<BodySlot> bodies;
  std::vector<AttachmentSlot> attachments;
  ContactOptions contact;
  double time_s = 0.0;
  int64_t steps = 0;

  detail::WorldWork& work() { return *work_; }

 private:
  std::unique_ptr<detail::WorldWork> work_;
};

/// Adds a body. Every body of a world steps at the same dt.
/// \note Throws lamina::Error (kInvalidInput) for a missing model, a simulation not made on it,
///   an empty or repeated name, a dt that differs from the world's, or a body that overlaps
///   another (or itself) at rest by more than contact.rest_overlap_tolerance_mm (naming both);
///   the world is then unchanged.
BodyId create_body(World& world, BodyDef def);

/// One organ as a world of one body without contact (neither with another body nor with
/// itself), which steps exactly as its simulation alone: what the one-organ loop
/// (organ_loop.h) and `lamina run` of one organ step. Its body is the world's first.
/// \note Throws lamina::Error (kInvalidInput) as create_body() does.
World one_body_world(BodyDef def);

/// Removes a body and the attachments that hold it; its handle (and theirs) become stale.
/// \note Throws lamina::Error (kInvalidInput) for a stale handle.
void destroy_body(World& world, BodyId id);

/// Whether `id` names a live body of `world`.
bool is_valid(const World& world, BodyId id);

/// The body `id` names.
/// \note Throws lamina::Error (kInvalidInput) "body handle N is stale ..." for a handle that
///   names no live body.
Body& body(World& world, BodyId id);
const Body& body(const World& world, BodyId id);

/// The handle of the live body named `name`, or an invalid handle (index -1).
BodyId find_body(const World& world, const std::string& name);

/// The live bodies' handles, in slot order (WorldStepStats::bodies' order).
std::vector<BodyId> body_ids(const World& world);

/// Ties two bodies where their skins meet at rest (AttachmentDef). Ties are pulled towards their
/// length each step, tear past their strength, and a blade divides them (divide_ties()).
/// \note Throws lamina::Error (kInvalidInput) for a stale handle, a body attached to itself, a
///   non-positive stiffness or strength, or skins that come nowhere within def.reach_mm (no tie
///   to make: the attachment would hold nothing).
AttachmentId create_attachment(World& world, const AttachmentDef& def);

/// The attachment `id` names.
/// \note Throws lamina::Error (kInvalidInput) for a stale handle.
Attachment& attachment(World& world, AttachmentId id);
const Attachment& attachment(const World& world, AttachmentId id);

/// A blade swept through the world this step: every active tie whose middle lies within
/// `reach_mm` of the swept surface (or within half its own length, a long tie) is divided, as
/// a dissection divides the connective tissue it passes through.
/// @return the ties divided
int32_t divide_ties(World& world, const BladeSweep& sweep, double reach_mm = 1.5);

/// Where a tie's two ends are now, mm: its node, and its point on the other body's skin.
std::pair<Eigen::Vector3d, Eigen::Vector3d> tie_ends(const World& world, const Tie& tie);

/// Ties of all attachments, and those divided or torn.
struct TieCount {
  int64_t total = 0;
  int64_t divided = 0;  ///< by a blade
  int64_t torn = 0;     ///< past their strength
};
TieCount count_ties(const World& world);

/// Advances every body one step (dt is the bodies'), in the stages WorldProfile names.
WorldStepStats step(World& world);
/// The same, into `out`, whose buffers are reused: a loop that keeps one allocates nothing
/// once the contacts' count has been reached.
void step(World& world, WorldStepStats& out);

/// Puts every body back at rest and every tie back in place.
void reset(World& world);

}  // namespace lamina::world
