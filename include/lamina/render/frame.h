#pragma once
/// \file
/// What one picture shows: the model at some positions, plus the interaction overlays of the
/// paper's figures (highlighted BFS rings, force arrows, contact and tool-tip spheres). Plain data,
/// filled by the viewer, `lamina render` and `lamina figures` alike, and drawn by render::Renderer.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "lamina/model/model.h"

namespace lamina::render {

/// How the layers inside the skin are shown.
enum class InnerLayers : uint8_t { kHidden, kTranslucent, kWireframe };
/// What colours the skin.
enum class Coloring : uint8_t {
  kOrgan,         ///< the organ's colour
  kDisplacement,  ///< distance from rest: organ colour (0), orange, pale yellow (the range's top)
};

/// How one of the model's embedded surfaces (Model::embedded) is drawn.
struct EmbeddedLook {
  bool visible = true;
  Eigen::Vector3f color{0.0f, 0.0f, 0.0f};  ///< a structure's; the display skin takes the skin's
};

/// Drawing choices, all live in the viewer's "Display" panel.
struct Style {
  InnerLayers inner = InnerLayers::kTranslucent;
  float skin_alpha = 1.0f;  ///< < 1 shows the inner layers through the skin
  bool skin_wireframe = false;
  bool springs = false;  ///< every spring as a line: layer edges grey, inter-layer links blue
  Coloring coloring = Coloring::kOrgan;
  float displacement_range_mm = 0.0f;  ///< kDisplacement: the red end; 0 = the frame's largest
  Eigen::Vector4f background{0.12f, 0.13f, 0.16f, 1.0f};
  Eigen::Vector3f organ_color{0.60f, 0.22f, 0.17f};  ///< liver red-brown
  /// The model's "display_skin" (an embedded surface at the segmentation's resolution), when it
  /// has one, is drawn in place of layer 0's triangles; false: the simulation's own skin.
  bool display_skin = true;
  /// One per Model::embedded entry (the display skin's `visible` is ignored: display_skin
  /// decides). Missing entries are drawn as embedded_look() says.
  std::vector<EmbeddedLook> embedded;
};

/// The default look of the model's embedded surface `index`: visible, in its colour by name or
/// order (model::structure_colors: portal vein violet, hepatic veins blue, tumours yellow, ...;
/// no two structures alike).
EmbeddedLook embedded_look(const Model& model, size_t index);

/// The style a model is first shown with: Style{}, and when it carries structures (embedded
/// surfaces other than the display skin) a skin of opacity 0.45 with the inner layers hidden, so
/// that the structures are seen through it; `embedded` filled by embedded_look().
Style default_style(const Model& model);

/// Triangles as a one-layer model the renderer and the viewer engine draw (a resection plane, a
/// segmentation's surface): no springs, no tetrahedra. `two_sided`: each triangle twice, once
/// each way, so that a translucent surface (drawn by its front faces) is seen from both sides.
Model mesh_model(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, bool two_sided = false);

/// The BFS rings 0..levels-1 of a node, coloured level by level as in the paper's figure 2.
struct RingHighlight {
  int32_t node = -1;
  int32_t levels = 0;  ///< at most the model's rings.locality
};

/// A force arrow from `from` to `to`, mm (the viewer scales forces to lengths).
struct Arrow {
  Eigen::Vector3d from = Eigen::Vector3d::Zero(), to = Eigen::Vector3d::Zero();
  Eigen::Vector4f color{1.0f, 0.85f, 0.1f, 1.0f};
};

/// A sphere: a contact point, a pinned force's anchor or the tool tip.
struct Marker {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  double radius_mm = 2.0;
  Eigen::Vector4f color{0.2f, 0.9f, 0.3f, 1.0f};
};

/// One picture's content. `model` and `x` are read during Renderer::draw() only.
struct Frame {
  const Model* model = nullptr;
  const Eigen::MatrixX3d* x = nullptr;  ///< #nodes by 3 positions, mm; nullptr = rest shape
  /// One per Model::embedded entry: its #V by 3 deformed vertices, mm, when the caller has them
  /// (model::embedded_positions of x); missing or nullptr: the renderer computes them from x
  /// (its rest positions V when x is nullptr).
  std::vector<const Eigen::MatrixX3d*> embedded_x;
  std::vector<RingHighlight> rings;
  std::vector<Arrow> arrows;
  std::vector<Marker> markers;
  Style style;
};

/// Colour of BFS level r (0 = the contact node) in ring highlights and figures.
Eigen::Vector4f ring_color(int32_t level);

/// Adds to `frame` (its model and positions must be set) an arrow for `force_mn` acting on
/// `node`, `mm_per_n` long per newton: a push (towards the organ's centre) arrives at the node
/// from outside, a pull leaves it, so the arrow stays visible outside the skin.
void add_force_arrow(Frame& frame, int32_t node, const Eigen::Vector3d& force_mn, double mm_per_n,
                     const Eigen::Vector4f& color = Arrow{}.color);

/// Adds a sphere on `node` sized for the model (1.2% of its rest bounding-box diagonal).
void add_contact_marker(Frame& frame, int32_t node,
                        const Eigen::Vector4f& color = {0.2f, 0.9f, 0.3f, 1.0f});

}  // namespace lamina::render
