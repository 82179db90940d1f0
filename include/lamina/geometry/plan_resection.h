#pragma once
/// \file
/// Resection planning on a patient's label volume: the future liver remnant, each tumour's
/// margin and the structures a resection surface divides (`lamina resect`, docs/resection.md).

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "lamina/core/grid.h"
#include "lamina/core/surface_role.h"
#include "lamina/geometry/couinaud_segments.h"
#include "lamina/geometry/functional_remnant.h"
#include "lamina/geometry/resection_surface.h"
#include "lamina/geometry/structure_names.h"

namespace lamina::geometry {

/// The liver's condition, which sets the least future liver remnant a team accepts (Table 1 of
/// PMC6422720: about 20% of a normal liver, 30% after more than three months of chemotherapy,
/// 40% of a fibrotic or cirrhotic one).
enum class LiverCondition { kNormal, kChemotherapy, kCirrhosis };
double flr_threshold_percent(LiverCondition condition);
const char* to_string(LiverCondition condition);

/// What places Couinaud's segments (ResectionOptions::segments_from).
enum class SegmentPlacement { kAuto, kVessels, kAtlas };

/// A structure of the segmentation: a tumour (its margin is measured) or a vessel or duct (its
/// crossings are found).
struct ResectionStructure {
  int32_t label = 0;
  std::string name;
  SurfaceRole role = SurfaceRole::kVessel;  ///< kTumour: its margin; otherwise its crossings
};

struct ResectionOptions {
  /// The organ's labels (their union; the structures' voxels it encloses join it, as in
  /// `lamina build`); empty: every label > 0.
  std::vector<int32_t> organ_labels;
  std::vector<ResectionStructure> structures;
  /// The remnant is the side holding this point (mm); none: the larger side.
  std::optional<Eigen::Vector3d> keep_point;
  double margin_mm = 10.0;  ///< the margin wanted around each tumour, mm
  LiverCondition liver = LiverCondition::kNormal;
  /// Couinaud's segments (couinaud_segments.h), and which of them the resection takes.
  bool segments = false;
  /// What places them: kAuto takes the vessels' landmarks when the portal vein and the hepatic
  /// veins come as two labels (their trees known apart), else the atlas (one label holding both:
  /// on 3D-IRCADb's livers the atlas scored a mean Dice of 0.79 against the merged vessels'
  /// 0.57), and the atlas when the vessels' landmarks are not found. kAtlas needs no vessels.
  SegmentPlacement segments_from = SegmentPlacement::kAuto;
};

/// A tumour (one connected piece of a tumour label) against the resection surface.
struct TumourMargin {
  std::string name;
  int32_t label = 0;
  int32_t piece = 1;  ///< 1.. for the label's pieces, largest first
  double volume_ml = 0.0;
  Eigen::Vector3d centre_mm = Eigen::Vector3d::Zero();
  /// "resected", "remnant", or "divided" (the surface passes through it)
  std::string side;
  /// The least distance between the tumour's voxels and the surface, mm (0 when divided)
  double margin_mm = 0.0;
  Eigen::Vector3d nearest_mm = Eigen::Vector3d::Zero();  ///< the surface's point nearest it
  /// Resected with at least the wanted margin
  bool clear = false;
  /// Its portal territory, when a portal vein is among the structures (none otherwise).
  std::optional<TumourTerritory> territory;
};

/// A place where the surface divides a structure (a vessel cut across).
struct StructureCrossing {
  std::string name;
  SurfaceRole role = SurfaceRole::kVessel;
  int32_t label = 0;
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();  ///< the section's centre, on the surface
  double area_mm2 = 0.0;                                  ///< the section's area
  double diameter_mm = 0.0;  ///< the circle of that area's: the local diameter
};

/// A connected piece of the remnant.
struct RemnantPiece {
  double volume_ml = 0.0;
  Eigen::Vector3d centre_mm = Eigen::Vector3d::Zero();
};

/// A remnant piece smaller than this is a sliver of voxels along the cut, not a finding.
inline constexpr double kMinPieceMl = 1.0;

struct ResectionReport {
  std::string input;
  double whole_ml = 0.0;  ///< the organ (with the structures it encloses)
  double remnant_ml = 0.0;
  double resected_ml = 0.0;
  double flr_percent = 0.0;  ///< remnant / whole
  double flr_threshold_percent = 0.0;
  bool flr_sufficient = false;
  LiverCondition liver = LiverCondition::kNormal;
  double margin_mm = 0.0;        ///< the margin wanted
  bool remnant_in_front = true;  ///< the remnant is on the surface's front
  std::vector<TumourMargin> tumours;
  std::vector<StructureCrossing> crossings;
  std::vector<RemnantPiece> remnant_pieces;  ///< >= kMinPieceMl, largest first
  double remnant_fragments_ml = 0.0;         ///< the smaller pieces' volume
  /// Voxels counted by their centres (the label volume written): remnant, resected
  int64_t remnant_voxels = 0, resected_voxels = 0;
  /// The functional remnant, when the structures hold a portal vein or hepatic veins (by name:
  /// vessel_tree_kind()); none otherwise, with the reason in functional_missing.
  std::optional<FunctionalRemnant> functional;
  double functional_flr_percent = 0.0;  ///< functional remnant / whole
  bool functional_sufficient = false;
  std::string functional_missing;
  /// Couinaud's segments, when asked for: where their planes were placed, each one's volume
  /// and the share of it the resection takes (by voxel centres), [1..8].
  std::optional<CouinaudLandmarks> segment_landmarks;
  /// Why the atlas placed them when the vessels were asked (auto) and their landmarks were not
  /// found; empty otherwise.
  std::string segment_fallback;
  std::array<double, 9> segment_ml{}, segment_resected_percent{};
};

/// A report's volumes, remnant side and future liver remnant from the organ's volume on each side
/// of the surface (both planners: the voxels', the model's). `keep_signed_mm`: the point to keep's
/// signed distance to the surface, none for the larger side.
/// \note Throws lamina::Error (kInvalidInput): the smaller side under `least_mm3` ("the resection
///   surface misses the organ", naming `source`), a point to keep on the surface ("--keep").
void fill_volumes(ResectionReport& report, double front_mm3, double back_mm3, double least_mm3,
                  std::optional<double> keep_signed_mm, const ResectionOptions& options,
                  const std::string& source);

/// Files the remnant's pieces (each centre already the volume's mean): those of kMinPieceMl or
/// more in remnant_pieces, largest first, the others' volume in remnant_fragments_ml.
void file_remnant_pieces(ResectionReport& report, const std::vector<RemnantPiece>& pieces);

struct ResectionPlan {
  ResectionReport report;
  /// On the input's grid: 1 for the remnant's voxels, 2 for the resected ones (by the side of
  /// each voxel's centre), 0 elsewhere.
  LabelVolume parts;
  /// The organ as planned (its labels, the structures it encloses, largest piece, cavities
  /// filled), cropped to its box with a voxel of background around: for its surface.
  Mask organ;
  /// The vessel trees with their territories (on the organ's grid), when the functional
  /// remnant was assessed.
  std::vector<VascularTree> trees;
  /// On the input's grid, when the functional remnant was assessed: each remnant voxel's
  /// function (kFunctional, kDevascularized, kCongested, kDevascularizedCongested), 0 elsewhere.
  LabelVolume function;
  /// On the input's grid, per tree: each organ voxel's branch (its id + 1), 0 outside the organ.
  std::vector<LabelVolume> territories;
  /// On the input's grid, when asked for: each organ voxel's Couinaud segment, 0 outside.
  LabelVolume segments;
};

/// The built-in phantom for planning: its carved-out anatomy (liver, portal vein, two tumours,
/// hepatic veins, vena cava), as a patient's labelmap stores them (lamina phantom --carved-out).
LabelVolume planning_phantom();
/// Its organ label and structures, named (`lamina resect` with no --label or --embed).
ResectionOptions planning_phantom_options();

/// Plans a resection of the organ in `volume` along `side`'s surface. Volumes count the voxels
/// whole where the surface misses them and split those it passes through exactly by the plane
/// (by the surface's tangent plane at its nearest point, for triangles); margins are the least
/// distance from a tumour's voxels (their boxes) to the surface; a structure is crossed where its
/// voxels inside the organ meet the surface, each connected set of those one crossing, its area
/// from their count (a voxel layer of thickness t holds area x t of volume). \note Throws
/// lamina::Error (kInvalidInput) naming volume.source for an organ label or
///   structure label that is absent, and for a surface that does not divide the organ (all of it
///   on one side: "the resection surface misses the organ").
ResectionPlan plan_resection(const LabelVolume& volume, const SideOf& side,
                             const ResectionOptions& options);

}  // namespace lamina::geometry
