#include "draw_embedded.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "lamina/model/cut_tetrahedra.h"
#include "lamina/model/embed_surface.h"

namespace lamina::render {

// Displacement as heat on the organ: its own colour at rest, through orange to pale yellow at the
// top of the range; monotonic in lightness, so it reads in greyscale and for colour-blind viewers.
Eigen::Vector4f displacement_color(const Eigen::Vector3f& organ, float t) {
  t = std::clamp(t, 0.0f, 1.0f);
  const Eigen::Vector3f mid(0.95f, 0.50f, 0.10f), top(1.0f, 0.95f, 0.55f);
  const Eigen::Vector3f c =
      t < 0.5f ? organ + (mid - organ) * (2.0f * t) : mid + (top - mid) * (2.0f * t - 1.0f);
  return {c[0], c[1], c[2], 1.0f};
}

EmbeddedDrawing::~EmbeddedDrawing() {
  release();
}

void EmbeddedDrawing::release() {
  for (Surface& s : surfaces_) {
    glDeleteBuffers(1, &s.vbo_pos);
    glDeleteBuffers(1, &s.vbo_normal);
    glDeleteBuffers(1, &s.vbo_color);
    glDeleteBuffers(1, &s.ebo);
    glDeleteVertexArrays(1, &s.vao);
  }
  surfaces_.clear();
}

void EmbeddedDrawing::upload_model(const Model& m) {
  if (surfaces_.size() != m.embedded.size()) {
    release();
    surfaces_.resize(m.embedded.size());
    for (Surface& s : surfaces_) {
      glGenVertexArrays(1, &s.vao);
      glGenBuffers(1, &s.vbo_pos);
      glGenBuffers(1, &s.vbo_normal);
      glGenBuffers(1, &s.vbo_color);
      glGenBuffers(1, &s.ebo);
    }
  }
  display_skin_ = model::display_skin_index(m);
  std::vector<uint32_t> idx;
  for (size_t i = 0; i < surfaces_.size(); ++i) {
    const EmbeddedSurface& e = m.embedded[i];
    Surface& s = surfaces_[i];
    const size_t n = static_cast<size_t>(e.V.rows());
    idx.resize(static_cast<size_t>(e.F.size()));
    for (Eigen::Index f = 0; f < e.F.rows(); ++f)
      for (int c = 0; c < 3; ++c) idx[3 * f + c] = static_cast<uint32_t>(e.F(f, c));
    s.indices = static_cast<GLsizei>(idx.size());
    glBindVertexArray(s.vao);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, s.ebo);
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(idx.size() * sizeof(uint32_t)),
                 idx.data(), GL_STATIC_DRAW);
    const GLuint buffers[3] = {s.vbo_pos, s.vbo_normal, s.vbo_color};
    for (GLuint a = 0; a < 3; ++a) {
      glBindBuffer(GL_ARRAY_BUFFER, buffers[a]);
      const GLint width = a == 2 ? 4 : 3;
      glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(n * width * sizeof(float)), nullptr,
                   GL_DYNAMIC_DRAW);
      glVertexAttribPointer(a, width, GL_FLOAT, GL_FALSE, 0, nullptr);
      glEnableVertexAttribArray(a);
    }
    // A structure has one colour: the constant attribute, set before its draw.
    if (static_cast<int32_t>(i) != display_skin_) glDisableVertexAttribArray(2);
    s.pos.resize(n * 3);
    s.normal.resize(n * 3);
    s.color.resize(static_cast<int32_t>(i) == display_skin_ ? n * 4 : 0);
    s.stale = true;
  }
  glBindVertexArray(0);
}

void EmbeddedDrawing::mark_stale() {
  for (Surface& s : surfaces_) s.stale = true;
}

bool EmbeddedDrawing::drawn(const Frame& fr, size_t i) const {
  if (static_cast<int32_t>(i) == display_skin_) return fr.style.display_skin;
  return i >= fr.style.embedded.size() || fr.style.embedded[i].visible;
}

// Positions, smooth normals (area-weighted face normals) and, for the display skin, the skin's
// colouring: its own displacement from rest, or the ring colour of its tetrahedron's
// most-weighted ringed corner.
void EmbeddedDrawing::fill(const Frame& fr, size_t i, const SkinColoring& coloring) {
  const EmbeddedSurface& e = fr.model->embedded[i];
  Surface& s = surfaces_[i];
  const Eigen::MatrixX3d* given = i < fr.embedded_x.size() ? fr.embedded_x[i] : nullptr;
  if (given && given->rows() != e.V.rows()) given = nullptr;
  if (!given && fr.x) {  // not given: computed here from the nodes' positions
    model::embedded_positions(e, *fr.x, s.x);
    given = &s.x;
  }
  const Eigen::MatrixX3d& x = given ? *given : e.V;
  const Eigen::Index n = x.rows();
  for (Eigen::Index v = 0; v < n; ++v)
    for (int c = 0; c < 3; ++c) s.pos[3 * v + c] = static_cast<float>(x(v, c));
  std::fill(s.normal.begin(), s.normal.end(), 0.0f);
  for (Eigen::Index f = 0; f < e.F.rows(); ++f) {
    const int a = e.F(f, 0), b = e.F(f, 1), c = e.F(f, 2);
    const Eigen::Vector3d nf = (x.row(b) - x.row(a)).cross(x.row(c) - x.row(a));
    for (int v : {a, b, c})
      for (int k = 0; k < 3; ++k) s.normal[3 * v + k] += static_cast<float>(nf[k]);
  }
  for (Eigen::Index v = 0; v < n; ++v) {
    float* nv = &s.normal[3 * v];
    const float len = std::sqrt(nv[0] * nv[0] + nv[1] * nv[1] + nv[2] * nv[2]);
    if (len > 0.0f) nv[0] /= len, nv[1] /= len, nv[2] /= len;
  }
  if (static_cast<int32_t>(i) == display_skin_) {
    const Style& st = fr.style;
    const float range = coloring.displacement_range_mm;
    const std::vector<int8_t>* rings = coloring.ring_level;
    for (Eigen::Index v = 0; v < n; ++v) {
      Eigen::Vector4f c(st.organ_color[0], st.organ_color[1], st.organ_color[2], 1.0f);
      if (st.coloring == Coloring::kDisplacement && range > 0.0f)
        c = displacement_color(st.organ_color,
                               static_cast<float>((x.row(v) - e.V.row(v)).norm()) / range);
      if (rings) {
        int best = -1;
        for (int k = 0; k < 4; ++k) {
          const int32_t node = e.corners(v, k);
          if ((*rings)[node] >= 0 && (best < 0 || e.weights(v, k) > e.weights(v, best))) best = k;
        }
        if (best >= 0) c = ring_color((*rings)[e.corners(v, best)]);
      }
      for (int q = 0; q < 4; ++q) s.color[4 * v + q] = c[q];
    }
  }
  glBindBuffer(GL_ARRAY_BUFFER, s.vbo_pos);
  glBufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(s.pos.size() * sizeof(float)),
                  s.pos.data());
  glBindBuffer(GL_ARRAY_BUFFER, s.vbo_normal);
  glBufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(s.normal.size() * sizeof(float)),
                  s.normal.data());
  if (!s.color.empty()) {
    glBindBuffer(GL_ARRAY_BUFFER, s.vbo_color);
    glBufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(s.color.size() * sizeof(float)),
                    s.color.data());
  }
  s.stale = false;
}

void EmbeddedDrawing::prepare(const Frame& fr, const SkinColoring& coloring) {
  for (size_t i = 0; i < surfaces_.size(); ++i)
    if (surfaces_[i].stale && drawn(fr, i)) fill(fr, i, coloring);
}

void EmbeddedDrawing::draw_structures(const Frame& fr, GLint u_lit) {
  glUniform1i(u_lit, 1);
  // Closed and wound outward: their back faces are hidden, and a software rasteriser (llvmpipe)
  // spends half the time it would on them.
  glEnable(GL_CULL_FACE);
  glCullFace(GL_BACK);
  for (size_t i = 0; i < surfaces_.size(); ++i) {
    if (static_cast<int32_t>(i) == display_skin_ || !drawn(fr, i)) continue;
    const Eigen::Vector3f c = i < fr.style.embedded.size() ? fr.style.embedded[i].color
                                                           : embedded_look(*fr.model, i).color;
    glBindVertexArray(surfaces_[i].vao);
    glVertexAttrib4f(2, c[0], c[1], c[2], 1.0f);
    // The wound lies where a cut closed the skin's pieces (their caps, on the same plane):
    // pulled towards the eye, it is drawn over them rather than fighting them for depth.
    const bool wound = fr.model->embedded[i].role == SurfaceRole::kWound;
    if (wound) glEnable(GL_POLYGON_OFFSET_FILL), glPolygonOffset(-1.0f, -2.0f);
    glDrawElements(GL_TRIANGLES, surfaces_[i].indices, GL_UNSIGNED_INT, nullptr);
    if (wound) glDisable(GL_POLYGON_OFFSET_FILL);
  }
  glDisable(GL_CULL_FACE);
  glBindVertexArray(0);
}

bool EmbeddedDrawing::draw_display_skin(const Frame& fr) {
  if (display_skin_ < 0 || !fr.style.display_skin) return false;
  glBindVertexArray(surfaces_[display_skin_].vao);
  glDrawElements(GL_TRIANGLES, surfaces_[display_skin_].indices, GL_UNSIGNED_INT, nullptr);
  glBindVertexArray(0);
  return true;
}

}  // namespace lamina::render
