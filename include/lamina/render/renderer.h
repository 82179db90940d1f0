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
  /// `frame.model` stays the same object with the same sizes; positions are uploaded each call.
  void draw(const Frame& frame, const Camera& camera, int width, int height);

  /// Forgets the uploaded model, e.g. after the model was rebuilt in place.
  void forget_model();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lamina::render
