#pragma once
/// \file
/// A scalpel through a body of a world: the one place where a body's topology changes. The body
/// is cut as a single organ is (interact::cut_now: the blade drawn at its current positions,
/// carried to rest, the virtual node algorithm), its simulation and tools carried over to the
/// copies, and then everything the world itself holds by the body's node numbers is renumbered
/// with it: the ties of every attachment on its nodes or on its skin's triangles, its nodes'
/// rest overlaps, and the contact's caches of its skin (grids, clearances, near lists), made
/// again on the next step. The body's topology generation moves on, so that what a caller kept
/// of the older one (a node number, a live force) is refused rather than applied to another
/// node (docs/world.md, "Cutting a body").

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "lamina/interact/prepared_cut.h"
#include "lamina/interact/scalpel.h"
#include "lamina/model/cut_tetrahedra.h"
#include "lamina/world/world.h"

namespace lamina::world {

/// Each node's first copy after a cut (-1 for none): what a tie, a tool by vertex or a live force
/// on the node is carried to (it is on the skin when the node was). `origin`: cut_body()'s, per
/// new node the old node it came from; `old_nodes`: the body's node count before the cut.
std::vector<int32_t> first_copies(const std::vector<int32_t>& origin, int32_t old_nodes);

/// Cuts body `id` along a blade drawn at its current positions: its upper end along `path`,
/// reaching depth_mm along `direction` (an interact::Scalpel's blade). A blade that divides none
/// of its tetrahedra changes nothing (the topology generation stays).
/// @param[out] origin  if given: per node of the cut body, the node of the body before it came
///                     from (the identity when nothing was cut)
/// @return what the cut did (structures crossed where they are now)
/// \note Throws lamina::Error (kInvalidInput), nothing changed, for a stale handle, a blade a
///   scalpel could not be (interact::scalpel_problem) or a body without tetrahedra.
model::CutReport cut_body(World& world, BodyId id, const std::vector<Eigen::Vector3d>& path,
                          const Eigen::Vector3d& direction, double depth_mm,
                          std::vector<int32_t>* origin = nullptr);

/// A scene's scalpels moving through body `id` (interact::ScalpelDriver, made for the body's
/// model): moved to the world's time, each cut they make is the body's as cut_body()'s is, with
/// everything the world holds by its node numbers renumbered and its topology generation moved on.
/// @return the cuts made (most steps none); the structures crossed where they are now
/// \note Throws lamina::Error (kInvalidInput) for a stale handle.
std::vector<interact::CutEvent> advance_scalpels(World& world, BodyId id,
                                                 interact::ScalpelDriver& scalpels);

struct WorldBefore;

/// cut_body() in two halves (interact/prepared_cut.h), for a loop that steps on while the cut is
/// made: interact::prepare_cut() on copies of the body's model and state (any thread), then this,
/// between two steps: the prepared cut taken into body `id` (its simulation and tools carried,
/// as interact::take_cut() does) and everything the world holds by its nodes renumbered, as
/// cut_body() does. `prepared` must have been made from the body's model as it is now (a loop
/// checks its topology generation); it is emptied.
/// @param[out] origin  as cut_body()'s
/// @param[in,out] before  when given, the body as it was kept there as keep_before() keeps it
///   (unless kept already), its simulation moved there rather than copied
/// \note Throws lamina::Error (kInvalidInput) for a stale handle, or a prepared cut of another
///   model (its origin does not match the body's nodes).
/// @param[in]     parameters_changed  the body's material or solver changed since the cut was
///   prepared: the cut simulation takes the body's of now (a change of dt is seen without it)
model::CutReport take_cut(World& world, BodyId id, interact::PreparedCut& prepared,
                          std::vector<int32_t>* origin = nullptr, WorldBefore* before = nullptr,
                          bool parameters_changed = false);

/// A body as it was before a change of its topology, and the ties of the world then: what
/// put_back() restores (a loop's reset after cuts).
struct BodyBefore {
  BodyId id;
  std::shared_ptr<const Model> model;
  sim::Simulation sim;
  interact::ToolDriver tools;
  std::vector<double> rest_overlap_mm;
  /// Per node after the change, the node of this body it came from (take_cut()'s origin, which
  /// a loop's undo carries the live forces back through); empty when kept by keep_before().
  std::vector<int32_t> origin = {};
};
struct WorldBefore {
  std::vector<BodyBefore> bodies;      ///< each body once, as it was before its first change
  std::vector<std::vector<Tie>> ties;  ///< per attachment slot, before the first change
};

/// Keeps body `id` in `before` as it is now, unless it is there already (its first change is
/// what a reset goes back to); the ties too, the first time anything is kept.
void keep_before(const World& world, BodyId id, WorldBefore& before);

/// cut_body(), keeping the body as it was in `before` (as keep_before() does) if the blade
/// divides it: what a loop's reset goes back to.
model::CutReport cut_body(World& world, BodyId id, const std::vector<Eigen::Vector3d>& path,
                          const Eigen::Vector3d& direction, double depth_mm, WorldBefore& before);

/// A scalpel through the whole world at once.
struct WorldCut {
  std::vector<std::pair<BodyId, model::CutReport>> bodies;  ///< those divided, in slot order
  /// The bodies the blade could not cut ("NAME: why": one without tetrahedra), or empty.
  std::string skipped;
  int32_t ties_divided = 0;
};

/// Cuts every body the blade passes through (cut_body(), each kept in `before` if divided), a
/// body without tetrahedra skipped and named, then divides the ties within reach_mm of the blade
/// (dissect_along()): what a user's scalpel stroke does to a world (the world loop's cut(),
/// Python's World.cut).
/// \note Throws lamina::Error (kInvalidInput), nothing changed, for a stroke check_stroke()
///   refuses.
WorldCut cut_through(World& world, const std::vector<Eigen::Vector3d>& path,
                     const Eigen::Vector3d& direction, double depth_mm, double reach_mm,
                     WorldBefore& before);

/// Puts every body kept in `before` back as it was, and the ties, through the same renumbering
/// as a cut (each body's topology generation moves on again); `before` is emptied.
void put_back(World& world, WorldBefore& before);

/// Folds `later` (kept after `earlier`: a later cut's undo) into `earlier`: the bodies and the
/// ties `earlier` does not hold yet are moved there, the others dropped (the earliest state is
/// what a reset goes back to); `later` is emptied.
void fold_before(WorldBefore& earlier, WorldBefore& later);

}  // namespace lamina::world
