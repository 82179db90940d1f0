#pragma once
/// \file
/// OpenIGTLink on the wire for `lamina serve` (docs/openigtlink.md): checking a header and a body
/// read from the network, the tool position in a TRANSFORM or POSITION, and the messages the
/// server sends. OpenIGTLink 1.11 converts byte orders, computes CRCs and packs the bodies; what
/// it trusts blindly (a body size from the network, a body of the wrong size for its type, the
/// extended header of header version 2) is checked here first.

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace lamina::net::igtlink {

inline constexpr size_t kHeaderBytes = 58;  ///< every OpenIGTLink message starts with these

/// A message header as read from the wire, in host byte order.
struct Header {
  uint16_t version = 1;  ///< 1, or 2 (OpenIGTLink 3: the body starts with an extended header)
  std::string type;      ///< device type, e.g. "TRANSFORM", "GET_POLYDATA"
  std::string device;    ///< device name; may be empty
  uint64_t body_bytes = 0;
  uint64_t crc = 0;  ///< CRC-64 of the whole body
};

/// Reads the kHeaderBytes at `bytes` as a header.
/// \note Throws lamina::Error (kInvalidInput) naming the problem when they are not a header (a
///   version other than 1 or 2, a type or name that is not text) or declare a body larger than
///   `max_body_bytes`.
Header read_header(const uint8_t* bytes, uint64_t max_body_bytes);

/// Where a body's content lies: the whole body for header version 1; for version 2, between the
/// extended header and the metadata.
struct Content {
  size_t offset = 0;
  size_t size = 0;
};

/// Checks a complete body (header.body_bytes at `body`) against the header's CRC and, for header
/// version 2, its extended header's sizes.
/// \note Throws lamina::Error (kInvalidInput) naming the problem.
Content check_body(const Header& header, const uint8_t* body);

/// How positions are written on the wire. The model is in LPS (ITK's physical space); 3D Slicer
/// and OpenIGTLink's TRANSFORM are RAS: x and y change sign, a rotation by 180 degrees about z.
enum class Frame : uint8_t { kRas, kLps };

/// A point or vector from the model's LPS frame to `frame`, or back (the change is its own
/// inverse).
Eigen::Vector3d change_frame(const Eigen::Vector3d& p, Frame frame);

/// The position in a TRANSFORM's or POSITION's content (its translation), mm, as sent.
/// \note Throws lamina::Error (kInvalidInput) for a content of the wrong size for its type, or a
///   position that is not finite.
Eigen::Vector3d read_position(const std::string& type, const uint8_t* content, size_t size);

/// A tracked tool's pose: where it is and where its z axis points (a scalpel's blade, from its
/// back towards its edge's tip), both as sent.
struct Pose {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Vector3d z_axis = Eigen::Vector3d::UnitZ();  ///< unit length
};

/// The pose in a TRANSFORM (the rotation's third column) or POSITION (its quaternion turning the
/// z axis; a POSITION without one: the z axis itself).
/// \note Throws lamina::Error (kInvalidInput) as read_position(), and for an axis that is not
///   finite or has no length.
Pose read_pose(const std::string& type, const uint8_t* content, size_t size);

/// A packed message, shared by every client it is queued for.
using Packed = std::shared_ptr<const std::vector<uint8_t>>;

/// A TRANSFORM with identity rotation and translation `t` (header version 1, wall-clock time).
Packed pack_transform(const std::string& device, const Eigen::Vector3d& t);

/// A STRING message (US-ASCII: its text must be), header version 1, wall-clock time.
Packed pack_string(const std::string& device, const std::string& text);

/// The text of a STRING message's content (encoding, length, the bytes).
/// \note Throws lamina::Error (kInvalidInput) when the length disagrees with the content's size,
///   or the text is not printable US-ASCII (encoding 3, the protocol's default).
std::string read_string(const uint8_t* content, size_t size);

/// POLYDATA messages of one surface whose triangles never change. The whole message is laid out
/// once, cells included; each pack() writes only the points, the time stamp and the CRC, in place
/// when no client still holds the previous message (no allocation frame to frame).
/// \note The bytes are those igtl::PolyDataMessage packs (header version 1, no attributes).
class PolyDataPacker {
 public:
  /// @param[in] device  the device name the messages carry (at most 20 characters)
  /// @param[in] F       #F by 3 triangles, indices into the points given to pack()
  /// @param[in] points  how many points each message has
  PolyDataPacker(std::string device, const Eigen::MatrixX3i& F, int32_t points);

  /// Packs `points` (#points by 3, mm, in the model's LPS frame), written in `frame`, with the
  /// triangles. `timestamp` is OpenIGTLink's (seconds << 32 | fraction); 0 = now.
  Packed pack(const Eigen::Ref<const Eigen::MatrixX3d>& points, Frame frame,
              uint64_t timestamp = 0);
  const std::string& device() const { return device_; }
  size_t message_bytes() const { return message_->size(); }

 private:
  std::string device_;
  int32_t points_ = 0;
  std::shared_ptr<std::vector<uint8_t>> message_;  // header, then body; shared with the queues
};

}  // namespace lamina::net::igtlink
