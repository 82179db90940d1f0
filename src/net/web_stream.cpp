// WebStream (web_stream.h): the browser's stream laid out once per model, then one compressed
// frame at a time. Byte layouts: docs/web.md "The stream".
#include "web_stream.h"

#include <meshoptimizer.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>

#include "lamina/core/error.h"
#include "lamina/model/embed_surface.h"
#include "lamina/model/structure_colors.h"

namespace lamina::net::web {
namespace {

constexpr size_t kPointBytes = 8;  // x, y, z as uint16 and a zero: the codec wants 4-byte steps

template <class T>
void put(std::string& out, T value) {
  char b[sizeof(T)];
  std::memcpy(b, &value, sizeof(T));  // little-endian machines only (x86-64, arm64)
  out.append(b, sizeof(T));
}

// meshoptimizer's vertex codec over `count` items of `size` bytes, appended with its length.
void put_encoded(std::string& out, const void* items, size_t count, size_t size) {
  const size_t at = out.size();
  put<uint32_t>(out, 0);
  if (count == 0) return;
  const size_t bound = meshopt_encodeVertexBufferBound(count, size);
  out.resize(at + 4 + bound);
  const size_t n = meshopt_encodeVertexBuffer(reinterpret_cast<unsigned char*>(out.data() + at + 4),
                                              bound, items, count, size);
  out.resize(at + 4 + n);
  const uint32_t n32 = static_cast<uint32_t>(n);
  std::memcpy(out.data() + at, &n32, 4);
}

struct Reader {
  const std::string& m;
  size_t at = 0;
  template <class T>
  T get() {
    if (m.size() - at < sizeof(T)) throw invalid_input("web stream", "message cut off");
    T v;
    std::memcpy(&v, m.data() + at, sizeof(T));
    at += sizeof(T);
    return v;
  }
  // A vertex-codec block of `count` items of `size` bytes into `out`.
  void decoded(void* out, size_t count, size_t size) {
    const uint32_t n = get<uint32_t>();
    if (m.size() - at < n) throw invalid_input("web stream", "encoded block cut off");
    if (count > 0 &&
        meshopt_decodeVertexBuffer(out, count, size,
                                   reinterpret_cast<const unsigned char*>(m.data() + at), n) != 0)
      throw invalid_input("web stream", "encoded block does not decode");
    at += n;
  }
};

}  // namespace

WebStream::WebStream(std::shared_ptr<const Model> model, const nlohmann::json& session, Carry carry,
                     std::vector<model::Rgb8> colors)
    : model_(std::move(model)) {
  const Model& m = *model_;
  // Drawn: every embedded surface (the display skin and the structures); a model without them,
  // its skin layer.
  for (size_t e = 0; e < m.embedded.size(); ++e) drawn_.push_back(static_cast<int32_t>(e));
  if (colors.size() != m.embedded.size()) colors = model::structure_colors(m);
  nlohmann::json surfaces = nlohmann::json::array();
  // `organ`: the organ's own surface (the display skin, a cut's wound), drawn translucent over
  // the anatomy, picked by a drag and framed by the first view; `role` says what each is.
  auto describe = [&](const std::string& name, SurfaceRole role, model::Rgb8 color, Eigen::Index nv,
                      Eigen::Index nt) {
    const bool organ = role == SurfaceRole::kDisplaySkin || role == SurfaceRole::kWound;
    surfaces.push_back({{"name", name},
                        {"role", std::string(role_name(role))},
                        {"color", {color[0], color[1], color[2]}},
                        {"vertices", nv},
                        {"triangles", nt},
                        {"organ", organ}});
    drawn_vertices_ += static_cast<size_t>(nv);
    drawn_triangles_ += static_cast<size_t>(nt);
  };
  if (drawn_.empty()) {
    const ModelLayer& skin = m.layers[0];
    describe("skin", SurfaceRole::kDisplaySkin, model::kOrganColor, skin.node_count, skin.F.rows());
  } else {
    for (const int32_t e : drawn_) {
      const EmbeddedSurface& s = m.embedded[static_cast<size_t>(e)];
      describe(s.name, s.role, colors[static_cast<size_t>(e)], s.V.rows(), s.F.rows());
    }
  }
  by_nodes_ = carry == Carry::kAuto ? static_cast<size_t>(m.node_count()) < drawn_vertices_
                                    : carry == Carry::kNodes;

  // The streamed points at rest, and the box they are quantized in: twice the rest's largest
  // extent about its centre, so that a pull of a whole organ length stays inside; 16 bits give
  // steps of 10 um on a 300 mm liver.
  Eigen::MatrixX3d rest;
  if (by_nodes_) {
    rest = m.X;
  } else {
    rest.resize(static_cast<Eigen::Index>(drawn_vertices_), 3);
    Eigen::Index row = 0;
    if (drawn_.empty()) {
      rest = m.X.middleRows(m.layers[0].first_node, m.layers[0].node_count);
    } else {
      for (const int32_t e : drawn_) {
        Eigen::MatrixX3d v;
        model::embedded_positions(m.embedded[static_cast<size_t>(e)], m.X, v);
        rest.middleRows(row, v.rows()) = v;
        row += v.rows();
      }
    }
  }
  const Eigen::Vector3d lo = rest.colwise().minCoeff(), hi = rest.colwise().maxCoeff();
  const double extent = std::max((hi - lo).maxCoeff(), 1.0);
  origin_ = 0.5 * (lo + hi) - Eigen::Vector3d::Constant(extent);
  step_ = 2.0 * extent / 65535.0;
  quantize(rest, rest_q_);

  hello_ = {{"type", "hello"},
            {"protocol", 1},
            {"carried_by", by_nodes_ ? "nodes" : "vertices"},
            {"points", rest.rows()},
            {"origin_mm", {origin_.x(), origin_.y(), origin_.z()}},
            {"step_mm", step_},
            {"surfaces", surfaces}};
  for (const auto& [key, value] : session.items()) hello_[key] = value;

  // One kSurface message per drawn surface: its triangles (meshoptimizer's index codec) and, by
  // nodes, each vertex's four nodes, weights and rest offset (its vertex codec).
  for (size_t s = 0; s < std::max<size_t>(drawn_.size(), 1); ++s) {
    const bool layer = drawn_.empty();
    const EmbeddedSurface* e = layer ? nullptr : &m.embedded[static_cast<size_t>(drawn_[s])];
    Eigen::Matrix<uint32_t, Eigen::Dynamic, 3, Eigen::RowMajor> F;
    if (layer)
      F = (m.layers[0].F.array() - m.layers[0].first_node).cast<uint32_t>();
    else
      F = e->F.cast<uint32_t>();
    const size_t nv =
        layer ? static_cast<size_t>(m.layers[0].node_count) : static_cast<size_t>(e->V.rows());
    std::string out;
    put<uint32_t>(out, static_cast<uint32_t>(Kind::kSurface));
    put<uint32_t>(out, static_cast<uint32_t>(s));
    put<uint32_t>(out, static_cast<uint32_t>(nv));
    put<uint32_t>(out, static_cast<uint32_t>(F.rows()));
    const size_t indices = 3 * static_cast<size_t>(F.rows());
    const size_t bound = meshopt_encodeIndexBufferBound(indices, nv);
    std::vector<unsigned char> enc(bound);
    const size_t n = meshopt_encodeIndexBuffer(enc.data(), bound, F.data(), indices);
    put<uint32_t>(out, static_cast<uint32_t>(n));
    out.append(reinterpret_cast<const char*>(enc.data()), n);
    if (by_nodes_) {
      std::vector<uint32_t> corners(4 * nv);
      std::vector<float> weights(4 * nv, 0.0f), offsets(4 * nv, 0.0f);
      for (size_t v = 0; v < nv; ++v) {
        for (int c = 0; c < 4; ++c) {
          corners[4 * v + c] = layer ? static_cast<uint32_t>(m.layers[0].first_node + v)
                                     : static_cast<uint32_t>(e->corners(v, c));
          weights[4 * v + c] =
              layer ? (c == 0 ? 1.0f : 0.0f) : static_cast<float>(e->weights(v, c));
        }
        if (!layer && e->offsets.rows() > 0)
          for (int c = 0; c < 3; ++c) offsets[4 * v + c] = static_cast<float>(e->offsets(v, c));
      }
      put_encoded(out, corners.data(), nv, 16);
      put_encoded(out, weights.data(), nv, 16);
      put_encoded(out, offsets.data(), nv, 16);
    }
    setup_.push_back(std::move(out));
  }
  std::string rest_message;
  put<uint32_t>(rest_message, static_cast<uint32_t>(Kind::kRest));
  put<uint32_t>(rest_message, static_cast<uint32_t>(rest.rows()));
  put_encoded(rest_message, rest_q_.data(), static_cast<size_t>(rest.rows()), kPointBytes);
  setup_.push_back(std::move(rest_message));
}

std::string WebStream::hello(int client) const {
  nlohmann::json h = hello_;
  h["client"] = client;
  return h.dump();
}

void WebStream::quantize(const Eigen::MatrixX3d& points, std::vector<uint16_t>& out) const {
  out.resize(4 * static_cast<size_t>(points.rows()));
  for (Eigen::Index i = 0; i < points.rows(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const double q = std::round((points(i, c) - origin_[c]) / step_);
      // A point outside the box stays on its side (and a NaN at 0: never sent, the loop stops).
      out[4 * static_cast<size_t>(i) + c] =
          static_cast<uint16_t>(q >= 0.0 ? std::min(q, 65535.0) : 0.0);
    }
    out[4 * static_cast<size_t>(i) + 3] = 0;
  }
}

const std::string& WebStream::frame(const Eigen::MatrixX3d& x, const FrameInfo& info) {
  const Model& m = *model_;
  if (by_nodes_) {
    quantize(x, now_q_);
  } else {
    points_.resize(static_cast<Eigen::Index>(drawn_vertices_), 3);
    if (drawn_.empty()) {
      points_ = x.middleRows(m.layers[0].first_node, m.layers[0].node_count);
    } else {
      Eigen::Index row = 0;
      surface_points_.resize(drawn_.size());
      for (size_t s = 0; s < drawn_.size(); ++s) {
        Eigen::MatrixX3d& v = surface_points_[s];
        model::embedded_positions(m.embedded[static_cast<size_t>(drawn_[s])], x, v);
        points_.middleRows(row, v.rows()) = v;
        row += v.rows();
      }
    }
    quantize(points_, now_q_);
  }
  // The change from rest (mod 2^16): still parts are runs of zeros, which the codec's byte
  // deltas turn into almost nothing.
  for (size_t k = 0; k < now_q_.size(); ++k)
    now_q_[k] = static_cast<uint16_t>(now_q_[k] - rest_q_[k]);
  frame_.clear();
  put<uint32_t>(frame_, static_cast<uint32_t>(Kind::kFrame));
  put<uint32_t>(frame_, info.frame);
  put<uint32_t>(frame_, info.model_version);
  put<uint32_t>(frame_, 2);  // tools
  put<double>(frame_, info.time_s);
  put<double>(frame_, static_cast<double>(info.steps));
  put<double>(frame_, static_cast<double>(info.sent_at_us));
  for (const ToolInfo& t : info.tools) {
    put<int32_t>(frame_, t.client);
    put<int32_t>(frame_, t.hand);
    put<uint32_t>(frame_, t.pose);
    for (int c = 0; c < 3; ++c) put<float>(frame_, static_cast<float>(t.reaction_mn[c]));
  }
  put<float>(frame_, static_cast<float>(info.volume_change_percent));
  put<uint8_t>(frame_, info.tools[0].contact);
  put<uint8_t>(frame_, info.tools[1].contact);
  put<uint8_t>(frame_, info.unstable);
  put<uint8_t>(frame_, info.behind);
  put<uint32_t>(frame_, static_cast<uint32_t>(now_q_.size() / 4));
  put_encoded(frame_, now_q_.data(), now_q_.size() / 4, kPointBytes);
  return frame_;
}

std::vector<uint16_t> decode_rest(const std::string& message) {
  Reader r{message};
  if (r.get<uint32_t>() != static_cast<uint32_t>(Kind::kRest))
    throw invalid_input("web stream", "not a rest message");
  const uint32_t count = r.get<uint32_t>();
  std::vector<uint16_t> q(4 * static_cast<size_t>(count));
  r.decoded(q.data(), count, kPointBytes);
  return q;
}

std::vector<uint16_t> decode_frame(const std::string& message, const std::vector<uint16_t>& rest_q,
                                   FrameInfo* info) {
  Reader r{message};
  if (r.get<uint32_t>() != static_cast<uint32_t>(Kind::kFrame))
    throw invalid_input("web stream", "not a frame message");
  FrameInfo f;
  f.frame = r.get<uint32_t>();
  f.model_version = r.get<uint32_t>();
  if (r.get<uint32_t>() != 2) throw invalid_input("web stream", "a frame without its two tools");
  f.time_s = r.get<double>();
  f.steps = static_cast<int64_t>(r.get<double>());
  f.sent_at_us = static_cast<uint64_t>(r.get<double>());
  for (ToolInfo& t : f.tools) {
    t.client = r.get<int32_t>();
    t.hand = r.get<int32_t>();
    t.pose = r.get<uint32_t>();
    for (int c = 0; c < 3; ++c) t.reaction_mn[c] = r.get<float>();
  }
  f.volume_change_percent = r.get<float>();
  f.tools[0].contact = r.get<uint8_t>() != 0;
  f.tools[1].contact = r.get<uint8_t>() != 0;
  f.unstable = r.get<uint8_t>() != 0;
  f.behind = r.get<uint8_t>() != 0;
  const uint32_t count = r.get<uint32_t>();
  if (4 * static_cast<size_t>(count) != rest_q.size())
    throw invalid_input("web stream", "frame and rest differ in their point count");
  std::vector<uint16_t> q(rest_q.size());
  r.decoded(q.data(), count, kPointBytes);
  for (size_t k = 0; k < q.size(); ++k) q[k] = static_cast<uint16_t>(q[k] + rest_q[k]);
  if (info) *info = f;
  return q;
}

}  // namespace lamina::net::web
