#pragma once
/// \file
/// A scalpel drawn through a simulated organ: its blade's edge moves along a path while the
/// simulation runs, and the tetrahedra it has passed through are divided as it goes
/// (model::cut_tetrahedra, the virtual node algorithm). The blade is carried to the model's rest
/// shape where it is drawn (model::to_rest), so the cut follows the material the blade passed
/// through however the organ moves, and each cut sweeps the blade's recent path again: a
/// tetrahedron the blade's tip was inside at one cut is divided at the next, once the blade has
/// left it. The simulation, the tools' loads and the model carry over to every cut
/// (docs/architecture.md, "Cutting").

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "lamina/interact/tools.h"
#include "lamina/model/cut_tetrahedra.h"
#include "lamina/sim/simulation.h"

namespace lamina::interact {

/// A scalpel: the blade's upper end moves along `path` at constant speed from start_s to end_s,
/// the blade reaching depth_mm below it along depth_direction (into the tissue).
struct Scalpel {
  std::vector<Eigen::Vector3d> path;                           ///< mm, >= 2 points
  Eigen::Vector3d depth_direction = Eigen::Vector3d::UnitY();  ///< any length, not zero
  double depth_mm = 10.0;                                      ///< > 0
  double start_s = 0.0;                                        ///< at path[0] then...
  double end_s = 1.0;  ///< ...at the path's last point then, s (> start_s)
};

/// What is wrong with a scalpel (the key and the problem, as a scene names them), or nothing:
/// fewer than two points, a point not finite, a path of zero length, a depth <= 0, a direction
/// that is zero or along the path, end_s <= start_s.
std::optional<std::pair<std::string, std::string>> scalpel_problem(const Scalpel& scalpel);

/// One cut as it happened.
struct CutEvent {
  double time_s = 0.0;      ///< the simulated time it was made at
  int32_t scalpel = 0;      ///< which scalpel made it
  model::CutReport report;  ///< structures_cut: the structures first crossed at this cut
  double seconds = 0.0;     ///< wall time of the whole update (model, simulation, tools)
};

/// Cuts the model `sim` runs on along `rest_blade` (in the model's rest space) and carries the
/// simulation, the tools' loads, touched nodes and grasps, and the held forces over to the cut
/// model, which replaces `model`. A blade that divides no tetrahedron changes nothing.
/// @param[in,out] model   the model `sim` runs on (replaced by the cut one: keep it shared
///                        while anything still refers to the old one)
/// @param[in,out] sim     a simulation of *model
/// @param[in,out] driver  the tools acting on sim (their node indices follow the copies)
/// @param[in]     rest_blade  the blade's surface at rest
/// @param[out]    origin  #new nodes: the node of the old model each came from
/// @return what the cut did
/// @param[in]    options  the blade's tip at rest, for a progressive cut
model::CutReport cut_simulation(std::shared_ptr<const Model>& model, sim::Simulation& sim,
                                ToolDriver& driver, const model::Blade& rest_blade,
                                std::vector<int32_t>& origin,
                                const model::CutOptions& options = {});

/// The tools' part of cut_simulation(): their vertices, routes, touched and loaded nodes, grasps,
/// held forces and a loop's live hands (live routes, tip, hand) moved from `before`'s nodes to
/// their copies in `cut` (a load divided among a node's copies as its mass is).
void carry_tools(const Model& before, const Model& cut, const std::vector<int32_t>& origin,
                 ToolDriver& driver);

/// The model's part of cut_now(), which needs no simulation (a loop runs it on another thread
/// while it steps on): the blade drawn at positions `x` of `model`, carried to rest, divides
/// `model` into `cut` (model::cut_tetrahedra; `cut` is left empty and origin the identity when
/// it divides nothing); the structures crossed are reported at rest (model::from_rest() puts
/// them where the organ is).
/// \note Throws lamina::Error (kInvalidInput) as cut_now().
model::CutReport cut_model_now(const Model& model, const Eigen::MatrixX3d& x,
                               const std::vector<Eigen::Vector3d>& path,
                               const Eigen::Vector3d& direction, double depth_mm, Model& cut,
                               std::vector<int32_t>& origin);

/// Cuts `sim`'s model at once along a blade drawn at its current positions: the blade's upper
/// end along `path`, reaching `depth_mm` along `direction` (as a Scalpel's), carried to rest
/// and cut there (cut_simulation()); the report's structures_cut at their current positions.
/// \note Throws lamina::Error (kInvalidInput) as scalpel_problem() ("cut: KEY: problem") and
///   for a model without tetrahedra; nothing is changed then.
model::CutReport cut_now(std::shared_ptr<const Model>& model, sim::Simulation& sim,
                         ToolDriver& driver, const std::vector<Eigen::Vector3d>& path,
                         const Eigen::Vector3d& direction, double depth_mm,
                         std::vector<int32_t>& origin);

/// Scalpels moving through a run, and where each has cut so far.
struct ScalpelDriver {
  std::vector<Scalpel> scalpels;
  /// The blade cuts each time it has moved this far along its path (and at its end), mm;
  /// make_scalpel_driver() sets it to the model's mean tetrahedron edge: a tetrahedron is
  /// divided once the blade has passed through it, so cutting more often opens nothing sooner.
  double event_mm = 1.0;
  int32_t depth_rows = 1;  ///< rows of the blade across its depth (it bends with the organ)
  double reach_mm = 0.0;   ///< how far back along its path each cut sweeps again
  struct Progress {
    double done_mm = -1.0;                  ///< path length cut so far (< 0: not started)
    std::vector<double> s;                  ///< path length at each column of the blade at rest
    std::vector<Eigen::MatrixX3d> columns;  ///< depth_rows + 1 points each, at rest
    std::vector<model::StructureCut> reported;
    /// The fine surfaces as they were at this scalpel's first cut: each cut splits them afresh
    /// along the whole path so far (model::CutOptions::unsplit). Null while another scalpel
    /// was cutting when this one began: its cuts then split the model's surfaces as they are.
    std::shared_ptr<const std::vector<EmbeddedSurface>> unsplit;
    /// The columns the model's surfaces have been split along (0: none, or not known: a
    /// resumed run's next cut splits them along the whole path again)
    size_t split_columns = 0;
  };
  std::vector<Progress> progress;  ///< per scalpel
  /// The model as it was before this driver's first cut: the structures crossed are measured on
  /// it (at rest, where the blade is kept), since a cut splits the structures it crosses along
  /// the blade, and a cut model's no longer cross it.
  std::shared_ptr<const Model> uncut;
};

/// A driver for `scalpels` on `model`; none is no error (a driver that cuts nothing).
/// \note Throws lamina::Error (kInvalidInput) "SOURCE: scalpel[k].KEY: problem"
///   (scalpel_problem()), and "SOURCE: tools: a scalpel cuts the tetrahedra, and the model has
///   none ..." for a model without tetrahedra (`source`: the scene, or what gave the scalpels).
ScalpelDriver make_scalpel_driver(const std::vector<Scalpel>& scalpels, const Model& model,
                                  const std::string& source = "scalpel");

/// Moves the scalpels to sim.time_s and cuts where they have passed (cut_simulation()).
/// @param[out] origin  if given: per node of the model after this call, the node of the model
///                     before it that it came from, over every cut made (the identity if none),
///                     for whoever holds more by the model's node numbers (world::advance_scalpels)
/// @return the cuts made (most steps none)
std::vector<CutEvent> advance_scalpels(ScalpelDriver& scalpels, std::shared_ptr<const Model>& model,
                                       sim::Simulation& sim, ToolDriver& driver,
                                       std::vector<int32_t>* origin = nullptr);

/// Whether a scalpel is still to move at or after `time_s`.
bool scalpels_active(const ScalpelDriver& scalpels, double time_s);

}  // namespace lamina::interact
