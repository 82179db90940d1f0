#include "lamina/render/renderer.h"

#include <epoxy/gl.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "draw_embedded.h"
#include "lamina/core/error.h"
#include "lamina/geometry/mesh_measures.h"

namespace lamina::render {
namespace {

// One program draws everything: lit triangles (u_lit = 1) and flat lines (u_lit = 0).
constexpr const char* kVertexShader = R"(#version 330 core
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec4 a_color;
uniform mat4 u_view;
uniform mat4 u_proj;
out vec3 v_normal;
out vec3 v_pos;
out vec4 v_color;
void main() {
  vec4 p = u_view * vec4(a_pos, 1.0);
  v_pos = p.xyz;
  v_normal = mat3(u_view) * a_normal;
  v_color = a_color;
  gl_Position = u_proj * p;
}
)";

// Two lights fixed to the camera (a key from the upper left, a weak fill from the lower right)
// and a Blinn-Phong highlight: wet tissue is glossy. Back faces are lit as front faces, so a cut
// or inside view still reads.
constexpr const char* kFragmentShader = R"(#version 330 core
in vec3 v_normal;
in vec3 v_pos;
in vec4 v_color;
uniform int u_lit;
uniform float u_alpha;
out vec4 o_color;
void main() {
  vec4 c = v_color;
  if (u_lit != 0) {
    vec3 n = normalize(v_normal);
    if (!gl_FrontFacing) n = -n;
    vec3 to_eye = normalize(-v_pos);
    vec3 key = normalize(vec3(-0.35, 0.55, 1.0));
    vec3 fill = normalize(vec3(0.6, -0.3, 0.6));
    float diffuse = 0.75 * max(dot(n, key), 0.0) + 0.25 * max(dot(n, fill), 0.0);
    float spec = 0.30 * pow(max(dot(n, normalize(key + to_eye)), 0.0), 40.0);
    c.rgb = c.rgb * (0.20 + 0.85 * diffuse) + vec3(spec);
  }
  o_color = vec4(c.rgb, c.a * u_alpha);
}
)";

GLuint compile(GLenum type, const char* source) {
  const GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &source, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048] = {};
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    glDeleteShader(s);
    throw Error(ErrorKind::kUnavailable, std::string("OpenGL shader does not compile: ") + log);
  }
  return s;
}

// Interleaved vertex of generated overlay geometry (arrows, spheres).
struct OverlayVertex {
  float pos[3], normal[3], color[4];
};

void push_vertex(std::vector<OverlayVertex>& out, const Eigen::Vector3d& p,
                 const Eigen::Vector3d& n, const Eigen::Vector4f& c) {
  out.push_back({{float(p.x()), float(p.y()), float(p.z())},
                 {float(n.x()), float(n.y()), float(n.z())},
                 {c[0], c[1], c[2], c[3]}});
}

void add_sphere(std::vector<OverlayVertex>& out, const Marker& m) {
  constexpr int kRings = 10, kSegments = 16;
  constexpr double kPi = 3.14159265358979323846;
  auto point = [&](int i, int j) {
    const double th = kPi * i / kRings, ph = 2.0 * kPi * j / kSegments;
    return Eigen::Vector3d(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
  };
  for (int i = 0; i < kRings; ++i)
    for (int j = 0; j < kSegments; ++j) {
      const Eigen::Vector3d a = point(i, j), b = point(i + 1, j), c = point(i + 1, j + 1),
                            d = point(i, j + 1);
      for (const Eigen::Vector3d* n : {&a, &b, &c, &a, &c, &d})
        push_vertex(out, m.center + m.radius_mm * *n, *n, m.color);
    }
}

// A shaft and a cone, with thickness proportional to the scene, not to the force.
void add_arrow(std::vector<OverlayVertex>& out, const Arrow& a, double scene_radius) {
  constexpr int kSegments = 14;
  constexpr double kPi = 3.14159265358979323846;
  const Eigen::Vector3d d = a.to - a.from;
  const double length = d.norm();
  if (!(length > 1e-9)) return;
  const Eigen::Vector3d axis = d / length;
  const Eigen::Vector3d u = axis.unitOrthogonal(), w = axis.cross(u);
  const double r = 0.008 * scene_radius, head = std::min(0.35 * length, 7.0 * r);
  const Eigen::Vector3d neck = a.to - head * axis;
  for (int j = 0; j < kSegments; ++j) {
    const double p0 = 2.0 * kPi * j / kSegments, p1 = 2.0 * kPi * (j + 1) / kSegments;
    const Eigen::Vector3d n0 = std::cos(p0) * u + std::sin(p0) * w;
    const Eigen::Vector3d n1 = std::cos(p1) * u + std::sin(p1) * w;
    // shaft
    push_vertex(out, a.from + r * n0, n0, a.color);
    push_vertex(out, neck + r * n0, n0, a.color);
    push_vertex(out, neck + r * n1, n1, a.color);
    push_vertex(out, a.from + r * n0, n0, a.color);
    push_vertex(out, neck + r * n1, n1, a.color);
    push_vertex(out, a.from + r * n1, n1, a.color);
    // cone (normals tilted by the cone's half-angle) and its base
    const double slope = 2.5 * r / head;
    const Eigen::Vector3d c0 = (n0 + slope * axis).normalized(),
                          c1 = (n1 + slope * axis).normalized();
    push_vertex(out, neck + 2.5 * r * n0, c0, a.color);
    push_vertex(out, a.to, (c0 + c1).normalized(), a.color);
    push_vertex(out, neck + 2.5 * r * n1, c1, a.color);
    push_vertex(out, neck, -axis, a.color);
    push_vertex(out, neck + 2.5 * r * n1, -axis, a.color);
    push_vertex(out, neck + 2.5 * r * n0, -axis, a.color);
  }
}

}  // namespace

struct Renderer::Impl {
  GLuint program = 0, vao = 0, vbo_pos = 0, vbo_normal = 0, vbo_color = 0, ebo = 0;
  GLuint overlay_vao = 0, overlay_vbo = 0;
  GLint u_view = -1, u_proj = -1, u_lit = -1, u_alpha = -1;

  // The uploaded model: identity and sizes, and where each range sits in the index buffer.
  const Model* model = nullptr;
  int32_t nodes = -1;
  size_t springs = 0;
  struct Range {
    size_t first = 0, count = 0;  // in indices
  };
  std::vector<Range> triangles, edges;  // per layer
  Range intra_springs, inter_springs;

  std::vector<float> pos, normal, color;  // per node, reused
  std::vector<int8_t> ring_level;         // per node: the ring colouring it, -1 = none; reused
  SkinColoring skin_coloring;             // how the display skin follows the skin's colours
  EmbeddedDrawing embedded;
  bool vertices_sent = false;  // the vertex buffers hold this model's vertices
  std::vector<OverlayVertex> overlay;

  void upload_model(const Model& m) {
    std::vector<uint32_t> idx;
    triangles.assign(m.layers.size(), {});
    edges.assign(m.layers.size(), {});
    for (size_t k = 0; k < m.layers.size(); ++k) {
      const Eigen::MatrixX3i& F = m.layers[k].F;
      triangles[k].first = idx.size();
      for (Eigen::Index f = 0; f < F.rows(); ++f)
        for (int c = 0; c < 3; ++c) idx.push_back(static_cast<uint32_t>(F(f, c)));
      triangles[k].count = idx.size() - triangles[k].first;
    }
    for (size_t k = 0; k < m.layers.size(); ++k) {
      edges[k].first = idx.size();
      for (const auto& [a, b] : geometry::mesh_edges(m.layers[k].F))
        idx.push_back(static_cast<uint32_t>(a)), idx.push_back(static_cast<uint32_t>(b));
      edges[k].count = idx.size() - edges[k].first;
    }
    for (SpringKind kind : {SpringKind::kIntraLayer, SpringKind::kInterLayer}) {
      Range& r = kind == SpringKind::kIntraLayer ? intra_springs : inter_springs;
      r.first = idx.size();
      for (size_t e = 0; e < m.springs.size(); ++e)
        if (m.springs.kind[e] == kind)
          idx.push_back(static_cast<uint32_t>(m.springs.i[e])),
              idx.push_back(static_cast<uint32_t>(m.springs.j[e]));
      r.count = idx.size() - r.first;
    }
    const size_t n = static_cast<size_t>(m.node_count());
    glBindVertexArray(vao);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, ebo);
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(idx.size() * sizeof(uint32_t)),
                 idx.data(), GL_STATIC_DRAW);
    for (GLuint b : {vbo_pos, vbo_normal}) {
      glBindBuffer(GL_ARRAY_BUFFER, b);
      glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(n * 3 * sizeof(float)), nullptr,
                   GL_DYNAMIC_DRAW);
    }
    glBindBuffer(GL_ARRAY_BUFFER, vbo_color);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(n * 4 * sizeof(float)), nullptr,
                 GL_DYNAMIC_DRAW);
    glBindVertexArray(0);
    model = &m;
    vertices_sent = false;
    nodes = m.node_count();
    springs = m.springs.size();
    pos.resize(n * 3);
    normal.resize(n * 3);
    color.resize(n * 4);
    ring_level.resize(n);
    embedded.upload_model(m);
  }

  // Positions, smooth normals (area-weighted face normals, per layer) and colours, per node.
  void fill_vertices(const Frame& fr) {
    const Model& m = *fr.model;
    const Eigen::MatrixX3d& x = fr.x ? *fr.x : m.X;
    const int32_t n = m.node_count();
    for (int32_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) pos[3 * i + c] = static_cast<float>(x(i, c));
    std::fill(normal.begin(), normal.end(), 0.0f);
    for (const ModelLayer& layer : m.layers)
      for (Eigen::Index f = 0; f < layer.F.rows(); ++f) {
        const int a = layer.F(f, 0), b = layer.F(f, 1), c = layer.F(f, 2);
        const Eigen::Vector3d nf = (x.row(b) - x.row(a)).cross(x.row(c) - x.row(a));
        for (int v : {a, b, c})
          for (int k = 0; k < 3; ++k) normal[3 * v + k] += static_cast<float>(nf[k]);
      }
    for (int32_t i = 0; i < n; ++i) {
      float* nv = &normal[3 * i];
      const float len = std::sqrt(nv[0] * nv[0] + nv[1] * nv[1] + nv[2] * nv[2]);
      if (len > 0.0f) nv[0] /= len, nv[1] /= len, nv[2] /= len;
    }

    const Style& st = fr.style;
    float range = st.displacement_range_mm;
    if (st.coloring == Coloring::kDisplacement && range <= 0.0f && fr.x)
      range = static_cast<float>(std::sqrt((x - m.X).rowwise().squaredNorm().maxCoeff()));
    const int32_t layers = m.layer_count();
    for (int32_t i = 0; i < n; ++i) {
      const int32_t k = m.layer_of.empty() ? 0 : m.layer_of[i];
      Eigen::Vector4f c;
      if (k == 0 && st.coloring == Coloring::kDisplacement) {
        const float d = fr.x ? static_cast<float>((x.row(i) - m.X.row(i)).norm()) : 0.0f;
        c = displacement_color(st.organ_color, range > 0.0f ? d / range : 0.0f);
      } else {
        // Inner layers fade from the organ colour towards a pale flesh tone with depth.
        const float t = layers > 1 ? 0.25f + 0.5f * static_cast<float>(k) / (layers - 1) : 0.0f;
        const Eigen::Vector3f pale(0.95f, 0.78f, 0.62f);
        const Eigen::Vector3f rgb = k == 0 ? st.organ_color : st.organ_color * (1 - t) + pale * t;
        c = {rgb[0], rgb[1], rgb[2], 1.0f};
      }
      for (int q = 0; q < 4; ++q) color[4 * i + q] = c[q];
    }
    skin_coloring.displacement_range_mm = st.coloring == Coloring::kDisplacement ? range : 0.0f;
    skin_coloring.ring_level = fr.rings.empty() ? nullptr : &ring_level;
    if (!fr.rings.empty()) std::fill(ring_level.begin(), ring_level.end(), int8_t{-1});
    for (const RingHighlight& h : fr.rings) {
      if (h.node < 0 || h.node >= n) continue;
      const int32_t levels = std::min(h.levels, m.rings.locality);
      for (int32_t r = levels - 1; r >= 0; --r) {  // inner rings drawn last, so they win
        const Eigen::Vector4f c = ring_color(r);
        const int32_t* ring = m.rings.ring(h.node, r);
        for (int64_t q = 0; q < m.rings.ring_size(h.node, r); ++q) {
          for (int s = 0; s < 4; ++s) color[4 * ring[q] + s] = c[s];
          ring_level[ring[q]] = static_cast<int8_t>(r);
        }
      }
    }
  }

  void draw_elements(GLenum mode, const Range& r) {
    if (r.count == 0) return;
    glDrawElements(mode, static_cast<GLsizei>(r.count), GL_UNSIGNED_INT,
                   reinterpret_cast<const void*>(r.first * sizeof(uint32_t)));
  }

  void draw_lines(const Range& r, const Eigen::Vector4f& c) {
    glUniform1i(u_lit, 0);
    glDisableVertexAttribArray(2);
    glVertexAttrib4f(2, c[0], c[1], c[2], c[3]);
    draw_elements(GL_LINES, r);
    glEnableVertexAttribArray(2);
  }
};

Renderer::Renderer() : impl_(std::make_unique<Impl>()) {
  if (epoxy_gl_version() < 33)
    throw Error(ErrorKind::kUnavailable, "OpenGL 3.3 core is needed, this context offers " +
                                             std::to_string(epoxy_gl_version() / 10) + "." +
                                             std::to_string(epoxy_gl_version() % 10));
  Impl& r = *impl_;
  const GLuint vs = compile(GL_VERTEX_SHADER, kVertexShader);
  const GLuint fs = compile(GL_FRAGMENT_SHADER, kFragmentShader);
  r.program = glCreateProgram();
  glAttachShader(r.program, vs);
  glAttachShader(r.program, fs);
  glLinkProgram(r.program);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(r.program, GL_LINK_STATUS, &ok);
  if (!ok) throw Error(ErrorKind::kUnavailable, "OpenGL shader program does not link");
  r.u_view = glGetUniformLocation(r.program, "u_view");
  r.u_proj = glGetUniformLocation(r.program, "u_proj");
  r.u_lit = glGetUniformLocation(r.program, "u_lit");
  r.u_alpha = glGetUniformLocation(r.program, "u_alpha");

  glGenVertexArrays(1, &r.vao);
  glGenBuffers(1, &r.vbo_pos);
  glGenBuffers(1, &r.vbo_normal);
  glGenBuffers(1, &r.vbo_color);
  glGenBuffers(1, &r.ebo);
  glBindVertexArray(r.vao);
  const GLuint buffers[3] = {r.vbo_pos, r.vbo_normal, r.vbo_color};
  for (GLuint a = 0; a < 3; ++a) {
    glBindBuffer(GL_ARRAY_BUFFER, buffers[a]);
    glVertexAttribPointer(a, a == 2 ? 4 : 3, GL_FLOAT, GL_FALSE, 0, nullptr);
    glEnableVertexAttribArray(a);
  }
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, r.ebo);

  glGenVertexArrays(1, &r.overlay_vao);
  glGenBuffers(1, &r.overlay_vbo);
  glBindVertexArray(r.overlay_vao);
  glBindBuffer(GL_ARRAY_BUFFER, r.overlay_vbo);
  const GLsizei stride = sizeof(OverlayVertex);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride,
                        reinterpret_cast<const void*>(offsetof(OverlayVertex, pos)));
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride,
                        reinterpret_cast<const void*>(offsetof(OverlayVertex, normal)));
  glVertexAttribPointer(2, 4, GL_FLOAT, GL_FALSE, stride,
                        reinterpret_cast<const void*>(offsetof(OverlayVertex, color)));
  for (GLuint a = 0; a < 3; ++a) glEnableVertexAttribArray(a);
  glBindVertexArray(0);
}

Renderer::~Renderer() {
  // The context may already be gone when the process exits; deleting names is then harmless.
  Impl& r = *impl_;
  glDeleteBuffers(1, &r.vbo_pos);
  glDeleteBuffers(1, &r.vbo_normal);
  glDeleteBuffers(1, &r.vbo_color);
  glDeleteBuffers(1, &r.ebo);
  glDeleteBuffers(1, &r.overlay_vbo);
  glDeleteVertexArrays(1, &r.vao);
  glDeleteVertexArrays(1, &r.overlay_vao);
  glDeleteProgram(r.program);
}

void Renderer::forget_model() {
  impl_->model = nullptr;
}

double scene_radius(const Model& m, const Camera& camera) {
  const Eigen::Vector3d lo = m.X.colwise().minCoeff(), hi = m.X.colwise().maxCoeff();
  return 0.5 * (hi - lo).norm() + (camera.target - 0.5 * (lo + hi)).norm();
}

void Renderer::draw(const Frame& fr, const Camera& camera, int width, int height,
                    const DrawPass& pass) {
  Impl& r = *impl_;
  const Style& st = fr.style;
  glViewport(0, 0, width, height);
  if (pass.clear) {
    glClearColor(st.background[0], st.background[1], st.background[2], st.background[3]);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  }
  if (!fr.model || fr.model->node_count() == 0) return;
  const Model& m = *fr.model;
  if (r.model != &m || r.nodes != m.node_count() || r.springs != m.springs.size())
    r.upload_model(m);

  // Normals and colours follow the positions: an unchanged frame costs neither the CPU pass
  // over every face nor the transfer.
  glBindVertexArray(r.vao);
  if (pass.upload_vertices || !r.vertices_sent) {
    r.fill_vertices(fr);
    const size_t n = static_cast<size_t>(m.node_count());
    glBindBuffer(GL_ARRAY_BUFFER, r.vbo_pos);
    glBufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(n * 3 * sizeof(float)),
                    r.pos.data());
    glBindBuffer(GL_ARRAY_BUFFER, r.vbo_normal);
    glBufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(n * 3 * sizeof(float)),
                    r.normal.data());
    glBindBuffer(GL_ARRAY_BUFFER, r.vbo_color);
    glBufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(n * 4 * sizeof(float)),
                    r.color.data());
    r.vertices_sent = true;
    r.embedded.mark_stale();
  }
  r.embedded.prepare(fr, r.skin_coloring);

  const double scene_radius =
      pass.scene_radius_mm > 0.0 ? pass.scene_radius_mm : render::scene_radius(m, camera);
  const Eigen::Matrix4f view = view_matrix(camera).cast<float>();
  const Eigen::Matrix4f proj =
      projection_matrix(camera, static_cast<double>(width) / std::max(height, 1),
                        1.3 * scene_radius)
          .cast<float>();
  glUseProgram(r.program);
  glUniformMatrix4fv(r.u_view, 1, GL_FALSE, view.data());
  glUniformMatrix4fv(r.u_proj, 1, GL_FALSE, proj.data());
  glUniform1f(r.u_alpha, 1.0f);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);
  glEnable(GL_BLEND);
  glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
  glDisable(GL_CULL_FACE);

  // 1. Structures inside the organ (embedded surfaces), opaque: drawn before anything
  // translucent, so that a translucent layer or skin blends over them.
  r.embedded.draw_structures(fr, r.u_lit);
  glBindVertexArray(r.vao);
  // 2. Inner layers, deepest first.
  const bool see_inside = st.inner != InnerLayers::kHidden;
  for (int32_t k = m.layer_count() - 1; k >= 1 && see_inside; --k) {
    if (st.inner == InnerLayers::kWireframe) {
      const float t = static_cast<float>(k) / m.layer_count();
      r.draw_lines(r.edges[k], {0.95f, 0.75f - 0.3f * t, 0.55f - 0.3f * t, 0.9f});
    } else {
      glUniform1i(r.u_lit, 1);
      glUniform1f(r.u_alpha, 0.55f);
      glEnable(GL_CULL_FACE);
      glCullFace(GL_BACK);
      r.draw_elements(GL_TRIANGLES, r.triangles[k]);
      glDisable(GL_CULL_FACE);
      glUniform1f(r.u_alpha, 1.0f);
    }
  }
  // 3. Springs.
  if (st.springs) {
    r.draw_lines(r.intra_springs, {0.75f, 0.75f, 0.75f, 0.6f});
    r.draw_lines(r.inter_springs, {0.35f, 0.6f, 1.0f, 0.8f});
  }
  // 4. Overlays: arrows and spheres, opaque, so they show through a translucent skin.
  r.overlay.clear();
  for (const Arrow& a : fr.arrows) add_arrow(r.overlay, a, scene_radius);
  for (const Marker& mk : fr.markers) add_sphere(r.overlay, mk);
  if (!r.overlay.empty()) {
    glBindVertexArray(r.overlay_vao);
    glBindBuffer(GL_ARRAY_BUFFER, r.overlay_vbo);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(r.overlay.size() * sizeof(OverlayVertex)),
                 r.overlay.data(), GL_STREAM_DRAW);
    glUniform1i(r.u_lit, 1);
    glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(r.overlay.size()));
    glBindVertexArray(r.vao);
  }
  // 5. The skin (the display skin in its place when shown), pushed back a little so its wireframe
  // wins the depth test; translucent skins draw front faces only and leave the depth buffer to what
  // is inside.
  glUniform1i(r.u_lit, 1);
  glEnable(GL_POLYGON_OFFSET_FILL);
  glPolygonOffset(1.0f, 1.0f);
  const bool translucent = st.skin_alpha < 0.999f;
  if (translucent) {
    glEnable(GL_CULL_FACE);
    glCullFace(GL_BACK);
    glDepthMask(GL_FALSE);
    glUniform1f(r.u_alpha, std::max(st.skin_alpha, 0.0f));
  }
  if (!r.embedded.draw_display_skin(fr)) r.draw_elements(GL_TRIANGLES, r.triangles[0]);
  glBindVertexArray(r.vao);
  glDepthMask(GL_TRUE);
  glDisable(GL_CULL_FACE);
  glDisable(GL_POLYGON_OFFSET_FILL);
  glUniform1f(r.u_alpha, 1.0f);
  if (st.skin_wireframe) r.draw_lines(r.edges[0], {0.1f, 0.05f, 0.05f, 0.45f});
  glBindVertexArray(0);
  glUseProgram(0);
}

}  // namespace lamina::render
