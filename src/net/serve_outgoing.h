#pragma once
// What `lamina serve` sends over OpenIGTLink, packed from a model's positions (a loop's snapshot):
// the layers' surfaces (LaminaSkin, LaminaLayerK), the embedded surfaces (named as in the model,
// after the body in a world: liver_portal_vein) and the tissue's reaction (LaminaReaction), each
// packer laid out once for a model with its triangles. A cut makes another model: a new Outgoing
// is made for it (IgtlSession::sent_for, WorldIgtlSession's per body).

#include <Eigen/Core>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "igtl_wire.h"
#include "lamina/model/model.h"

namespace lamina::net {

/// OpenIGTLink's device names hold at most this many characters.
inline constexpr size_t kMaxDeviceName = 20;

/// The device name of layer k's POLYDATA: LaminaSkin for the skin, LaminaLayer1... inside.
std::string layer_device(int32_t k);

/// The tissue's push on the tools (mN, the model's LPS) as the TRANSFORM LaminaReaction, its
/// translation written in `frame`.
igtlink::Packed reaction_message(const Eigen::Vector3d& reaction_mn, igtlink::Frame frame);

/// The device names an Outgoing sends under. One organ's: LaminaSkin and LaminaLayerK, its
/// embedded surfaces by their names; a world body's: its skin under the body's name, no inner
/// layer, its embedded surfaces after the body (liver_portal_vein).
struct OutgoingNames {
  std::string skin = "LaminaSkin";  ///< layer 0's device (layer_device(0))
  bool inner_layers = true;         ///< LaminaLayerK for the layers inside the skin
  std::string prefix;               ///< before each embedded surface's name
  std::set<std::string> taken;      ///< what other messages are sent as
};

class Outgoing {
 public:
  /// Laid out for `model` (kept while sent); an embedded surface's device is names.prefix and
  /// its name; one the wire cannot carry, or that another message has (names.taken, or this
  /// model's own), is said in the log and not sent.
  Outgoing(std::shared_ptr<const Model> model, igtlink::Frame frame, OutgoingNames names = {});

  /// A GET_POLYDATA names a layer (LaminaLayerK) or an embedded surface; any other name means
  /// the skin (the protocol's example client asks as "Client"). `x`: the model's positions.
  igtlink::Packed requested(const Eigen::MatrixX3d& x, const std::string& device);
  /// Layer k (0, the skin; the inner ones only with names.inner_layers).
  igtlink::Packed layer(const Eigen::MatrixX3d& x, int32_t k);
  const std::string& skin_device() const { return names_.skin; }
  /// The embedded surface's points W x; its buffers are kept from one frame to the next.
  igtlink::Packed embedded(const Eigen::MatrixX3d& x, int32_t e);
  int32_t embedded_count() const { return static_cast<int32_t>(embedded_.size()); }
  /// The embedded surface sent as `device`, or -1.
  int32_t find_embedded(const std::string& device) const;
  igtlink::Packed reaction(const Eigen::Vector3d& reaction_mn) const;
  /// One line per embedded surface sent: its size on the wire and (at exit) what a frame of it
  /// cost.
  void log_embedded(bool at_exit) const;

  static constexpr const char* kReactionDevice = "LaminaReaction";

 private:
  struct Embedded {
    const EmbeddedSurface* surface;
    igtlink::PolyDataPacker packer;
    Eigen::MatrixX3d points;  // W x, mm, LPS
    double pack_s = 0.0;      // time spent on W x and packing, s
    int64_t packs = 0;
  };
  int32_t requested_layer(const std::string& device) const;

  std::shared_ptr<const Model> shared_;  // a cut replaces the loop's: kept while sent
  const Model& model_;
  igtlink::Frame frame_;
  OutgoingNames names_;
  std::vector<igtlink::PolyDataPacker> layers_;
  std::vector<Embedded> embedded_;
};

}  // namespace lamina::net
