#pragma once
/// \file
/// The OpenGL 3.3 core renderer behind the viewer, `lamina render` and the figures: lit,
/// smooth-shaded skin with normals recomputed from the current positions, translucent or
/// wireframe inner layers, springs, rings, arrows and spheres. It draws into whatever framebuffer
/// is bound in the current context: a GLFW window or an offscreen one (render/offscreen.h).

#include <memory>

#include "lamina/render/camera.h"
#include "lamina/render/frame.h"

namespace lamina::render {

/// How one draw joins the others in a view of several models, and what it may reuse.
struct DrawPass {
  bool clear = true;  ///< clear to the frame's background first (false: draw over the others)
  /// The depth range's radius about the camera target, mm, shared by every model of one view;
  /// 0 = this model's own (scene_radius()).
  double scene_radius_mm = 0.0;
  /// false: reuse the positions, normals and colours sent by the last draw of this model (the
  /// caller knows that neither the positions nor the colouring changed). They are sent anyway
  /// when the model itself is new to this renderer.
  bool upload_vertices = true;
};

/// The radius about the camera target that holds the model's rest shape, mm: what the
/// projection's near and far planes bracket.
double scene_radius(const Model& model, const Camera& camera);

class Renderer {
 public:
  /// Compiles the shaders. Needs a current OpenGL 3.3 core context.
  /// \note Throws lamina::Error (kUnavailable) if the context is older than 3.3 or a shader
  ///   fails to compile (the message carries the driver's log).
  Renderer();
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  /// Draws `frame` seen by `camera` into the bound framebuffer's width x height viewport.
  /// Static buffers (triangles, edges, springs) are uploaded once per model and reused while
  /// `frame.model` stays the same object with the same sizes; positions are uploaded each call
  /// unless `pass` says they are unchanged.
  void draw(const Frame& frame, const Camera& camera, int width, int height,
            const DrawPass& pass = {});

  /// Forgets the uploaded model, e.g. after the model was rebuilt in place.
  void forget_model();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lamina::render
