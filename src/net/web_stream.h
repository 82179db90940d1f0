#pragma once
/// \file
/// What `lamina serve --web` streams to a browser (docs/web.md "The stream"): once per model,
/// the surfaces to draw (display skin, structures; or the layers when there is no display skin)
/// with their triangles, colours and names, and their rest shape; then every frame the newest
/// positions, quantized to 16 bits in the organ's box, as the change from rest, and compressed
/// with meshoptimizer's vertex codec (its JavaScript decoder reads them in the page).
///
/// Two ways to carry the shape, chosen per model by size: the model's nodes (the page computes
/// each drawn vertex as W x + offset from the embedding's corners and weights, sent once), or
/// the drawn vertices themselves. Nodes win whenever there are fewer of them than drawn
/// vertices, which is every model with a display skin (2.4k nodes against 50k+ vertices).

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "lamina/model/model.h"
#include "lamina/model/structure_colors.h"

namespace lamina::net::web {

/// Binary messages start with one of these (a little-endian uint32).
enum class Kind : uint32_t {
  kSurface = 1,  ///< one drawn surface's triangles (and, by nodes, its corners and weights)
  kRest = 2,     ///< the streamed points' rest positions, quantized
  kFrame = 3,    ///< the streamed points now, quantized, as the change from rest
};

/// A tool of the session (the tool tip, the grasper) as a frame reports it: who holds it and
/// the tissue's push on it, for the page that holds it to vibrate.
struct ToolInfo {
  int32_t client = -1;  ///< the web client holding it (-1: none, or an OpenIGTLink client)
  int32_t hand = -1;    ///< that client's hand (0 right, 1 left; the desktop's mouse: 0)
  uint32_t pose = 0;    ///< the holder's newest pose the positions reflect (its latency)
  Eigen::Vector3d reaction_mn = Eigen::Vector3d::Zero();
  bool contact = false;  ///< touching (the tip) or holding (the grasper) tissue
};

/// The per-frame facts sent with the positions.
struct FrameInfo {
  uint32_t frame = 0;          ///< counts frames sent since the server started
  uint32_t model_version = 0;  ///< changes with the model (a cut): a new hello follows
  double time_s = 0.0;         ///< simulated time
  int64_t steps = 0;
  uint64_t sent_at_us = 0;  ///< the server's clock when encoded
  ToolInfo tools[2];        ///< 0: the tool tip, 1: the grasper
  double volume_change_percent = 0.0;
  bool unstable = false;  ///< the simulation blew up and is being reset
  bool behind = false;    ///< the machine cannot keep real time
};

/// How the shape travels: chosen by size (kAuto), or forced (the benchmark measures both).
enum class Carry : uint8_t { kAuto, kNodes, kVertices };

class WebStream {
 public:
  /// Lays out the stream for `model` (kept alive while streamed); `session`'s fields (the
  /// tools' limits, the rate) join the hello.
  /// `colors`: one per embedded surface (a world's organs, docs/world.md); empty: each
  /// structure's own (model::structure_colors).
  WebStream(std::shared_ptr<const Model> model, const nlohmann::json& session,
            Carry carry = Carry::kAuto, std::vector<model::Rgb8> colors = {});

  /// The model's description, a JSON text message for `client`: surfaces (name, colour, vertex
  /// and triangle counts), how the shape is carried ("nodes" or "vertices"), the quantization
  /// box, the session's fields, and the client's own id (frames name a tool's holder by it).
  std::string hello(int client) const;
  /// The binary messages that follow the hello: one kSurface per surface, then kRest.
  const std::vector<std::string>& setup() const { return setup_; }

  /// One kFrame message for the node positions `x` (#nodes by 3, mm). Allocation-free after
  /// the first frame (its buffers are kept). Returns a reference to the stream's own buffer.
  const std::string& frame(const Eigen::MatrixX3d& x, const FrameInfo& info);

  const Model& model() const { return *model_; }
  bool by_nodes() const { return by_nodes_; }
  size_t streamed_points() const { return rest_q_.size() / 4; }
  size_t drawn_vertices() const { return drawn_vertices_; }
  size_t drawn_triangles() const { return drawn_triangles_; }
  /// The quantization: a point p is stored as round((p - origin) / step) in [0, 65535] per axis.
  Eigen::Vector3d origin_mm() const { return origin_; }
  double step_mm() const { return step_; }

 private:
  void quantize(const Eigen::MatrixX3d& points, std::vector<uint16_t>& out) const;

  std::shared_ptr<const Model> model_;
  bool by_nodes_ = true;
  std::vector<int32_t> drawn_;  // embedded surfaces drawn (indices), or empty: the layers
  size_t drawn_vertices_ = 0, drawn_triangles_ = 0;
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();
  double step_ = 1.0;
  nlohmann::json hello_;
  std::vector<std::string> setup_;
  std::vector<uint16_t> rest_q_;  // 4 per point (x, y, z, 0)
  // Per-frame buffers, kept.
  Eigen::MatrixX3d points_;
  std::vector<Eigen::MatrixX3d> surface_points_;  // W x of each drawn surface (by vertices)
  std::vector<uint16_t> now_q_;
  std::string frame_;
};

/// The page's decoding, in C++ for the tests and the benchmark: a kRest message's quantized
/// points (4 per point), and a kFrame message's (the rest's plus the frame's change). Throw
/// lamina::Error (kInvalidInput) on a malformed message.
std::vector<uint16_t> decode_rest(const std::string& message);
std::vector<uint16_t> decode_frame(const std::string& message, const std::vector<uint16_t>& rest_q,
                                   FrameInfo* info = nullptr);

}  // namespace lamina::net::web
