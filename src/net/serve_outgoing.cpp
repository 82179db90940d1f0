// lamina serve's outgoing messages (serve_outgoing.h).
#include "serve_outgoing.h"

#include <fmt/format.h>

#include <chrono>

#include "lamina/core/log.h"
#include "lamina/model/embed_surface.h"
#include "serve_clock.h"

namespace lamina::net {
namespace {

using Clock = ServeClock;

}  // namespace

std::string layer_device(int32_t k) {
  return k == 0 ? "LaminaSkin" : "LaminaLayer" + std::to_string(k);
}

Outgoing::Outgoing(std::shared_ptr<const Model> model, igtlink::Frame frame, OutgoingNames names)
    : shared_(std::move(model)), model_(*shared_), frame_(frame), names_(std::move(names)) {
  const Model& m = model_;
  const int32_t layers = names_.inner_layers ? m.layer_count() : 1;
  for (int32_t k = 0; k < layers; ++k) {
    const ModelLayer& layer = m.layers[static_cast<size_t>(k)];
    // The model's triangles index every node; a message indexes its own points.
    const Eigen::MatrixX3i F = layer.F.array() - layer.first_node;
    layers_.emplace_back(k == 0 ? names_.skin : layer_device(k), F, layer.node_count);
  }
  for (const EmbeddedSurface& e : m.embedded) {
    // A name the wire cannot carry, or one that another message already has, would reach a
    // client as some other surface: said, and that surface is not sent.
    const std::string device = names_.prefix + e.name;
    const bool taken = device == kReactionDevice || requested_layer(device) > 0 ||
                       device == names_.skin || find_embedded(device) >= 0 ||
                       names_.taken.count(device) > 0;
    if (e.name.empty() || device.size() > kMaxDeviceName || taken) {
      log::warn(
          "the embedded surface '{}' is not sent over OpenIGTLink: {} (rename it in the "
          "scene's build.embed)",
          device,
          taken ? "another message has that device name"
                : fmt::format("a device name has 1 to {} characters", kMaxDeviceName));
      continue;
    }
    embedded_.push_back({&e, igtlink::PolyDataPacker(device, e.F, static_cast<int32_t>(e.V.rows())),
                         Eigen::MatrixX3d()});
  }
}

igtlink::Packed Outgoing::requested(const Eigen::MatrixX3d& x, const std::string& device) {
  const int32_t e = find_embedded(device);
  return e >= 0 ? embedded(x, e) : layer(x, requested_layer(device));
}

igtlink::Packed Outgoing::layer(const Eigen::MatrixX3d& x, int32_t k) {
  const ModelLayer& l = model_.layers[static_cast<size_t>(k)];
  return layers_[static_cast<size_t>(k)].pack(x.middleRows(l.first_node, l.node_count), frame_);
}

igtlink::Packed Outgoing::embedded(const Eigen::MatrixX3d& x, int32_t e) {
  Embedded& out = embedded_[static_cast<size_t>(e)];
  const auto t0 = Clock::now();
  model::embedded_positions(*out.surface, x, out.points);
  igtlink::Packed message = out.packer.pack(out.points, frame_);
  out.pack_s += seconds(Clock::now() - t0);
  ++out.packs;
  return message;
}

igtlink::Packed reaction_message(const Eigen::Vector3d& reaction_mn, igtlink::Frame frame) {
  return igtlink::pack_transform(Outgoing::kReactionDevice,
                                 igtlink::change_frame(reaction_mn, frame));
}

igtlink::Packed Outgoing::reaction(const Eigen::Vector3d& reaction_mn) const {
  return reaction_message(reaction_mn, frame_);
}

void Outgoing::log_embedded(bool at_exit) const {
  for (const Embedded& e : embedded_) {
    if (at_exit && e.packs == 0) continue;
    const std::string cost =
        at_exit ? fmt::format(", {:.2f} ms per message to compute and pack ({} messages)",
                              1e3 * e.pack_s / static_cast<double>(e.packs), e.packs)
                : "";
    log::info("POLYDATA '{}': {} points, {} triangles, {:.0f} kB a message{}", e.packer.device(),
              e.surface->V.rows(), e.surface->F.rows(),
              static_cast<double>(e.packer.message_bytes()) / 1e3, cost);
  }
}

int32_t Outgoing::requested_layer(const std::string& device) const {
  for (int32_t k = 1; k < static_cast<int32_t>(layers_.size()); ++k)
    if (device == layer_device(k)) return k;
  return 0;
}

int32_t Outgoing::find_embedded(const std::string& device) const {
  for (size_t e = 0; e < embedded_.size(); ++e)
    if (embedded_[e].packer.device() == device) return static_cast<int32_t>(e);
  return -1;
}

}  // namespace lamina::net
