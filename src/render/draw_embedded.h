#pragma once
// The embedded surfaces' share of Renderer::draw (module render, private): the display skin drawn
// in place of layer 0's triangles, and the structures inside the organ (vessels, tumour) drawn
// opaque before anything translucent. Each surface has its own vertex array: its triangles are
// uploaded once per model, its positions, normals (and the display skin's colours) when the
// positions change, into buffers sized once.

#include <epoxy/gl.h>

#include <cstdint>
#include <vector>

#include "lamina/render/frame.h"

namespace lamina::render {

/// How the skin's nodes are coloured this frame, for the display skin to follow.
struct SkinColoring {
  float displacement_range_mm = 0.0f;  ///< kDisplacement's top; 0 = no displacement yet
  /// #nodes: the BFS ring level colouring each node, -1 for none
  const std::vector<int8_t>* ring_level = nullptr;
};

/// Displacement as heat: the organ's colour at t = 0 through orange to pale yellow at t = 1.
Eigen::Vector4f displacement_color(const Eigen::Vector3f& organ, float t);

class EmbeddedDrawing {
 public:
  EmbeddedDrawing() = default;
  ~EmbeddedDrawing();
  EmbeddedDrawing(const EmbeddedDrawing&) = delete;
  EmbeddedDrawing& operator=(const EmbeddedDrawing&) = delete;

  /// The model's triangles into index buffers, vertex buffers sized (a new model).
  void upload_model(const Model& m);
  /// The positions (or the colouring) changed: every surface is filled again before it is next
  /// drawn.
  void mark_stale();
  /// Fills and sends the vertices of the surfaces this frame draws that are stale.
  void prepare(const Frame& fr, const SkinColoring& coloring);
  /// The visible structures, opaque and lit. Needs the program bound; leaves no VAO bound.
  void draw_structures(const Frame& fr, GLint u_lit);
  /// The display skin's triangles, if the model has one and the style shows it (the caller set
  /// the skin's state: offset, alpha, culling). @return false when it drew nothing.
  bool draw_display_skin(const Frame& fr);

 private:
  struct Surface {
    GLuint vao = 0, vbo_pos = 0, vbo_normal = 0, vbo_color = 0, ebo = 0;
    GLsizei indices = 0;
    bool stale = true;
    Eigen::MatrixX3d x;                     // its vertices at the frame's x, when not given
    std::vector<float> pos, normal, color;  // per vertex, reused
  };
  void release();
  bool drawn(const Frame& fr, size_t i) const;
  void fill(const Frame& fr, size_t i, const SkinColoring& coloring);

  std::vector<Surface> surfaces_;
  int32_t display_skin_ = -1;
};

}  // namespace lamina::render
