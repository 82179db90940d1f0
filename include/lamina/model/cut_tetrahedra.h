#pragma once
/// \file
/// Cutting a model's tetrahedra along a blade's swept surface by the virtual node algorithm
/// (Molino, Bao & Fedkiw 2004): each tetrahedron the surface divides is replaced by two copies
/// at its own rest shape, one per side, each carrying the share of its material on that side
/// (Tets::share) and sharing no node across the cut. Copies on the same side of neighbouring
/// tetrahedra share their nodes where their material meets, so the cut opens exactly along the
/// divided tetrahedra and nowhere else. Nothing is deleted, no sliver is made, and the mass and
/// the tetrahedra's material volume are what they were (docs/architecture.md, "Cutting").

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "lamina/model/model.h"

namespace lamina::model {

/// The surface a blade sweeps: triangles, mm, in the space of the positions it cuts.
struct Blade {
  Eigen::MatrixX3d V;
  Eigen::MatrixX3i F;
};

/// What is wrong with a blade drawn along `path`, `depth_mm` along `depth_direction`, as a
/// key ("path", "path[k]", "depth_mm", "direction") and the problem, or nothing: fewer than two
/// points, a point not finite, a path of zero length, a depth <= 0, a direction that is zero or
/// runs along the path (it would sweep no surface). sweep_blade() and interact::scalpel_problem()
/// share it.
std::optional<std::pair<std::string, std::string>> blade_problem(
    const std::vector<Eigen::Vector3d>& path, const Eigen::Vector3d& depth_direction,
    double depth_mm);

/// The surface a scalpel's edge sweeps as it is drawn along a path: at each point of `path` the
/// edge runs from the point `depth_mm` along `depth_direction` (into the tissue); consecutive
/// edges span two triangles.
/// @param[in] path             >= 2 points, mm, not all the same
/// @param[in] depth_direction  the blade's direction into the tissue (normalised here); not
///                             along the path
/// @param[in] depth_mm         > 0
/// \note Throws lamina::Error (kInvalidInput) "blade KEY: problem" (blade_problem()).
Blade sweep_blade(const std::vector<Eigen::Vector3d>& path, const Eigen::Vector3d& depth_direction,
                  double depth_mm);

/// A connected part of a cut model's tetrahedra.
struct CutPiece {
  double volume_mm3 = 0.0;  ///< its tetrahedra's material volume (rest volume x share)
  double mass_kg = 0.0;     ///< its nodes' masses
  int64_t tets = 0;
  int32_t nodes = 0;
};

/// A structure the blade crosses (a vessel cut across: a surgical simulator's bleeding cue).
struct StructureCut {
  std::string name;                                       ///< the embedded surface's
  SurfaceRole role = SurfaceRole::kVessel;                ///< its role (is_anatomy())
  int32_t label = 0;                                      ///< its segmentation label
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();  ///< the cross-section's centre
  double area_mm2 = 0.0;                                  ///< the cross-section's area in the blade
  double diameter_mm = 0.0;  ///< the circle of that area's: the vessel's local diameter
  /// The section is a closed loop; false when the blade's surface ends inside the structure
  /// (a partial section: its area and diameter are of the part cut so far)
  bool closed = true;
};

/// Each crossing of an embedded structure (every embedded surface of the anatomy, at the
/// positions x) by the blade's surface, one per loop of the section; only the structure's
/// triangles that meet `near` are looked at (a progressive cut's newest part; pass the blade's
/// box for all).
std::vector<StructureCut> structures_crossed(const Model& model, const Eigen::MatrixX3d& x,
                                             const Blade& blade, const Eigen::Vector3d& near_lo,
                                             const Eigen::Vector3d& near_hi);

/// Points given against positions x carried to the model's rest shape: each at its barycentric
/// weights in the tetrahedron (at x) that holds it, or in the one near it that it is least
/// outside of. A blade drawn on the deformed organ, carried to rest, cuts the same material; at
/// rest it stays put while the organ moves, so a progressive cut can sweep its whole path so far.
/// \note Throws lamina::Error (kInvalidInput) for a model without tetrahedra, positions of the
///   wrong size or not finite, a point not finite, or points nowhere near the organ.
Eigen::MatrixX3d to_rest(const Model& model, const Eigen::MatrixX3d& x,
                         const Eigen::MatrixX3d& points);

/// The inverse of to_rest(): points at rest carried to where the tetrahedra put them at x.
Eigen::MatrixX3d from_rest(const Model& model, const Eigen::MatrixX3d& x,
                           const Eigen::MatrixX3d& points);

/// What a cut did.
struct CutReport {
  int64_t cut_tets = 0;  ///< tetrahedra divided: each is now two copies
  /// tetrahedra the surface crosses without dividing them (the blade's edge ends inside them):
  /// kept whole, so the cut ends there
  int64_t partly_cut_tets = 0;
  int32_t new_nodes = 0;         ///< nodes added (the copies' own nodes across the cut)
  std::vector<CutPiece> pieces;  ///< largest first
  /// Each crossing of an embedded structure by the blade, at the positions the blade was given
  /// against (one per closed loop of the crossing: a vessel cut across twice is two)
  std::vector<StructureCut> structures_cut;
  /// No tetrahedron divided, but the fine surfaces split along the blade (CutOptions::unsplit:
  /// a progressive scalpel past the tissue still inside a structure beside it, such as a vena
  /// cava along the liver's back): the model is a new one all the same.
  bool surfaces_split = false;
  /// Whether the cut model differs from the one cut.
  bool changed() const { return cut_tets > 0 || surfaces_split; }
};

/// The name of the embedded surface a cut adds to the model (role SurfaceRole::kWound): the
/// wound, each side's cut surface inside the organ, carried by the copies on that side
/// (its vertices on their edges), so it opens as the cut does. Each cut adds its part.
inline constexpr const char* kWoundName = "wound";

/// A copy never carries less than this share of its tetrahedron's material (nor more than one
/// minus it): a node the blade grazes keeps a mass and a stiffness in proportion, never a zero
/// pivot (the shares of the two copies still sum to the tetrahedron's own).
inline constexpr double kMinCutShare = 0.02;

/// No copy of a node takes less than this part of the node's mass (its siblings give it up in
/// proportion: the node's mass is kept exactly), whatever little material it carries: a copy
/// with a sliver's mass (0.4% of an ordinary node's with kMinCutShare's floor alone) was left
/// jittering at 0.5-1 mm/s, never at rest, in `lamina soak --cuts` (5% still at 0.1 mm/s; 15%
/// came to rest: docs/testing.md).
inline constexpr double kMinCopyMass = 0.15;

/// How a cut treats the tetrahedra at its blade's edge.
struct CutOptions {
  /// A progressive cut's blade tip, the segment [tip_from, tip_to] at the positions given (the
  /// leading edge, where the blade is now): the tetrahedra whose boxes meet its box stay whole,
  /// as the blade has not passed through them yet; a later cut divides them (a division made with
  /// the blade's edge inside a tetrahedron might not match the one its whole path makes, and a
  /// copy is not divided again). Off when tip_from is not finite.
  Eigen::Vector3d tip_from = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d tip_to = Eigen::Vector3d::Zero();
  /// Look for the structures the blade crosses (CutReport::structures_cut); a progressive cut,
  /// which looks for them along its recent path itself, turns it off.
  bool find_structures = true;
  /// A progressive cut's fine surfaces as they were before its first event (at rest), and the
  /// blade's whole path so far at rest: each event splits those afresh along it rather than the
  /// model's surfaces, already split along the path's earlier part, which a split along the same
  /// surface again would meet edge-on (CGAL's corefinement then leaves triangles of three
  /// collinear points across the cut). Their vertices are the first rows of the model's
  /// surfaces of the same name and label. Null: the model's own surfaces, along the blade.
  const std::vector<EmbeddedSurface>* unsplit = nullptr;
  const Blade* unsplit_blade = nullptr;
  /// The part of unsplit_blade the model's surfaces have not been split along yet (at rest,
  /// from the last column they were split to): only the unsplit triangles it reaches are split
  /// again, what the earlier events made of the others kept, so that an event's split does not
  /// grow with the path. Null: the whole of unsplit_blade.
  const Blade* unsplit_new = nullptr;
};

/// Cuts the tetrahedra the blade's surface divides.
/// @param[in]  model   a model with tetrahedra
/// @param[in]  x       #nodes by 3 positions the blade is given against (the rest positions, or
///                     a deformed state: a tetrahedron is divided where its deformed edges cross
///                     the surface, at the same fractions of its rest edges)
/// @param[in]  blade   the swept surface
/// @param[out] out     the cut model: nodes ordered by layer as before (a node's copies follow
///                     it), tetrahedra with their shares, springs along the new tetrahedra's
///                     edges, layer triangles on the copies that carry them, rings again, the
///                     embedded surfaces' vertices in the copy on their side
/// @param[out] origin  #out nodes: the node of `model` each came from
/// @param[out] report  counts and the pieces
/// \note Throws lamina::Error (kInvalidInput) naming the problem: no tetrahedra, positions of
///   the wrong size or not finite, a blade with no triangles or values not finite. A blade that
///   divides no tetrahedron is no error: `out` is then the model, with report.cut_tets = 0.
/// @param[in]  options  the blade's tip, for a progressive cut
void cut_tetrahedra(const Model& model, const Eigen::MatrixX3d& x, const Blade& blade, Model& out,
                    std::vector<int32_t>& origin, CutReport& report,
                    const CutOptions& options = {});

/// The share of its node's mass node `i` of a cut model carries (1 for a node the cut did not
/// copy; a node's copies' shares sum to 1): how a load or a support on the node is divided
/// among its copies.
/// @param[in] before  the model that was cut
/// @param[in] cut     the cut model
/// @param[in] origin  cut_tetrahedra()'s: the node of `before` each node of `cut` came from
inline double copy_share(const Model& before, const Model& cut, const std::vector<int32_t>& origin,
                         int32_t i) {
  const double m0 = before.mass_kg[static_cast<size_t>(origin[static_cast<size_t>(i)])];
  return m0 > 0.0 ? cut.mass_kg[static_cast<size_t>(i)] / m0 : 1.0;
}

/// Each tetrahedron of a cut model that the cut left as it was: the index of the same element
/// in `before` (the same corners, by origin, the same share and material: its rest shape and
/// constants are that one's), or -1 for a copy of a divided tetrahedron. Linear: it walks the
/// two lists together, as cut_tetrahedra() keeps the tetrahedra's order (a divided one's two
/// copies in its place); a cut model not so ordered gets -1 where the walk loses its way (the
/// caller then does the work afresh, never wrongly).
std::vector<int32_t> same_tets(const Model& before, const Model& cut,
                               const std::vector<int32_t>& origin);

/// Each spring of `before`: the one spring of the cut model between copies of its two ends, or
/// -1 where there is none or there are several (a spring at a node the cut copied). Linear: a
/// merge of the two sorted lists, the copies of a node following it (cut_tetrahedra()'s
/// numbering); all -1 for an origin that does not keep the nodes' order.
std::vector<int32_t> same_springs(const Model& before, const Model& cut,
                                  const std::vector<int32_t>& origin);

}  // namespace lamina::model
