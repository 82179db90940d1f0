#pragma once
/// \file
/// From a segmentation to the multi-layer mass-spring model: the whole model-building pipeline.

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "lamina/core/grid.h"
#include "lamina/core/progress.h"
#include "lamina/geometry/measure_tets.h"
#include "lamina/geometry/plug_tunnels.h"
#include "lamina/geometry/prepare_mask.h"
#include "lamina/model/model.h"

namespace lamina::model {

/// What fills the organ between the layers.
enum class Structure : uint8_t {
  /// Tetrahedra fill every shell between neighbouring layers and the core (conforming to the
  /// layers); the springs are their edges. The organ is a volume: it resists a change of side
  /// as well as of length.
  kTetrahedra,
  /// The reference paper's network: each node linked to its nearest nodes on the neighbouring
  /// layers (`inter_layer_links`), nothing between the surfaces.
  kLinks,
};

/// A structure carried inside the organ by its tetrahedra (a vessel tree, a tumour): a surface
/// extracted from a label of the organ's own segmentation, or from a separate mask on its grid,
/// embedded in the model (Model::embedded).
struct EmbedStructure {
  /// How it is shown and saved; empty = the mask file's name without its extensions (a separate
  /// mask), or "label N".
  std::string name;
  int32_t label = 0;  ///< its label; 0 (separate masks only) = every non-zero voxel
  /// nullptr: a label of the organ's own segmentation; else a separate mask, which must lie on
  /// the organ's grid (same size, spacing, origin and directions).
  std::shared_ptr<const LabelVolume> mask{};
  /// What it is (kVessel, kTumour or kStructure), stored with its surface; none: the role its
  /// name suggests (geometry::guess_role), said in the build report. It also decides what of
  /// its voxels the organ takes in (geometry::add_enclosed_structures): all of a tumour's.
  std::optional<SurfaceRole> role{};
};

/// The role a structure is built with: its own, else the one its name suggests.
SurfaceRole structure_role(const EmbedStructure& s);

/// Options for build_model(). Defaults reproduce the reference paper's layers, filled with
/// tetrahedra.
struct BuildOptions {
  Structure structure = Structure::kTetrahedra;  ///< what joins the layers
  int32_t label = 0;                             ///< label to model; 0 = any non-zero voxel
  /// When not empty: the organ is the union of these labels (`label` is ignored).
  std::vector<int32_t> labels;
  /// Triangles of the display skin (the organ's surface at the mask's own resolution, carried
  /// by the tetrahedra and drawn instead of the simulation's skin); 0 = none. Needs tetrahedra:
  /// a kLinks model gets none.
  int64_t display_triangles = 100000;
  std::vector<EmbedStructure> embed;    ///< structures carried inside the organ
  int64_t structure_triangles = 20000;  ///< triangle budget of each structure's surface
  int32_t layers = 2;                   ///< S: layer 0 is the skin, 1..S-1 nested inside; 1..16
  int32_t skin_vertices = 1284;         ///< target skin vertex count (the paper's model size)
  double layer_depth_mm = 0.0;          ///< depth between layers; 0 = auto (max depth / (S+1))
  int32_t locality = 4;                 ///< N: BFS rings 0..N-1 precomputed per node
  int32_t inter_layer_links =
      3;  ///< each node links to this many nearest nodes per neighbour layer
  double density_kg_per_mm3 = 1.06e-6;  ///< tissue density (liver 1.06 g/cm^3 = 1.06e-6 kg/mm^3)
  double stiffness_n_per_m = 3.0;       ///< Hooke constant of every spring (the paper's K = 3)
  int32_t min_component_vertices = 12;  ///< smaller pieces of an inner layer are dropped
  /// Tetrahedra: TetGen's radius-edge bound and dihedral-angle goal, degrees.
  double tet_radius_edge_ratio = 2.0;
  double tet_min_dihedral_deg = 10.0;
};

/// One layer as built.
struct LayerBuildInfo {
  int32_t index = 0;
  double depth_mm = 0.0;             ///< distance inside the skin of this layer's isosurface
  int32_t dropped_components = 0;    ///< tiny pieces removed (thin parts of the organ)
  double min_gap_to_outer_mm = 0.0;  ///< closest approach to the layer outside it (0 for the skin)
  bool nested = true;                ///< strictly inside the layer outside it
};

/// One embedded surface as built.
struct EmbeddedBuildInfo {
  std::string name;
  SurfaceRole role = SurfaceRole::kStructure;
  int32_t label = 0;
  int64_t vertices = 0, faces = 0;
  int32_t outside = 0;     ///< vertices in no tetrahedron at rest (they follow the nearest)
  double volume_ml = 0.0;  ///< the surface's enclosed volume
};

/// What the build did and measured, besides the model itself.
struct BuildReport {
  std::string input;
  geometry::MaskReport mask;
  std::array<double, 3> working_spacing_mm{};  ///< grid the distance field was computed on
  double max_depth_mm = 0.0;                   ///< deepest point inside the organ
  double target_edge_mm = 0.0;                 ///< edge length all layers were remeshed to
  /// Tunnels through the organ: the genus of its surface on the working grid, after the plugs
  /// (0: none)
  int32_t skin_genus = 0;
  /// Tunnels too narrow for the skin's triangles, plugged on the working grid
  geometry::TunnelPlugs tunnels;
  /// Gaps of the organ narrower than the skin's triangles, closed when the skin crossed itself
  /// in them (the working grid's closing by a ball of `radius_mm`; 0 voxels: none)
  struct ClosedGaps {
    double radius_mm = 0.0;
    int64_t voxels = 0;
    double volume_ml = 0.0;
  } gaps;
  /// Times the skin was made: 1, or more when it crossed itself and the mask was made again
  int32_t skin_attempts = 1;
  int32_t layers_requested = 0;
  std::vector<LayerBuildInfo> layers;       ///< one per built layer
  std::vector<std::string> warnings;        ///< vanished/split layers, dropped pieces
  double mask_volume_ml = 0.0;              ///< voxel volume of the prepared mask
  double skin_volume_error_pct = 0.0;       ///< (skin volume - mask volume) / mask volume
  geometry::TetQuality tets;                ///< the tetrahedra at rest (count 0 for kLinks)
  int32_t interior_nodes = 0;               ///< nodes the tetrahedral mesher added (on no layer)
  std::vector<EmbeddedBuildInfo> embedded;  ///< the display skin first, then each structure
  /// The structures' names and roles in BuildOptions::embed order (mask.structures' entries)
  std::vector<std::string> structure_names;
  std::vector<SurfaceRole> structure_roles;
  double build_seconds = 0.0;  ///< wall time of build_model (no file reading)
  std::vector<std::pair<std::string, double>> stage_seconds;  ///< per stage, in order
};

/// The model and its report.
struct BuildResult {
  Model model;
  BuildReport report;
};

/// Checks options before any work: throws lamina::Error (kInvalidInput) naming the option.
void check_build_options(const BuildOptions& options);

/// Runs the pipeline: prepare the mask, signed distance field, one isosurface per layer,
/// isotropic remeshing to the skin's target density, tetrahedra filling the shells and the core
/// (or, with Structure::kLinks, links between neighbouring layers), springs (the tetrahedra's
/// edges, or layer edges and links), lumped masses, BFS rings.
/// @param[in] volume    the segmentation (volume.source names it in messages)
/// @param[in] options   see BuildOptions
/// @param[in] progress  optional progress callback
/// \note Throws lamina::Error (kInvalidInput) for unusable input or options; a layer that
///   vanishes or splits is not an error: it is dropped or kept in pieces and reported.
BuildResult build_model(const LabelVolume& volume, const BuildOptions& options,
                        const ProgressFn& progress = {});

}  // namespace lamina::model
