#include "igtl_wire.h"

#include <igtlStringMessage.h>
#include <igtlTimeStamp.h>
#include <igtlTransformMessage.h>
#include <igtl_header.h>
#include <igtl_position.h>
#include <igtl_string.h>
#include <igtl_transform.h>
#include <igtl_util.h>

#include <algorithm>
#include <cassert>
#include <chrono>
#include <cmath>
#include <cstring>

#include "lamina/core/error.h"

namespace lamina::net::igtlink {
namespace {

Error bad(const std::string& problem) {
  return Error(ErrorKind::kInvalidInput, problem);
}

// A header's fixed-width text field: printable ASCII up to the first NUL. A device type is one
// word (no spaces); a device name may hold spaces (3D Slicer's node names do).
bool read_text(const char* field, size_t width, bool spaces, std::string& out) {
  out.clear();
  for (size_t i = 0; i < width && field[i] != '\0'; ++i) {
    const unsigned char c = static_cast<unsigned char>(field[i]);
    if (c < (spaces ? 0x20 : 0x21) || c > 0x7e) return false;
    out.push_back(static_cast<char>(c));
  }
  return true;
}

uint16_t big_endian_u16(const uint8_t* p) {
  return static_cast<uint16_t>(p[0] << 8 | p[1]);
}
uint32_t big_endian_u32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) << 24 | static_cast<uint32_t>(p[1]) << 16 |
         static_cast<uint32_t>(p[2]) << 8 | p[3];
}

Packed packed_bytes(igtl::MessageBase& message) {
  message.Pack();
  const auto* bytes = static_cast<const uint8_t*>(message.GetPackPointer());
  return std::make_shared<const std::vector<uint8_t>>(bytes, bytes + message.GetPackSize());
}

void stamp_now(igtl::MessageBase& message) {
  igtl::TimeStamp::Pointer now = igtl::TimeStamp::New();
  now->GetTime();
  message.SetTimeStamp(now);
}

}  // namespace

Header read_header(const uint8_t* bytes, uint64_t max_body_bytes) {
  igtl_header raw;
  static_assert(sizeof(raw) == kHeaderBytes);
  std::memcpy(&raw, bytes, kHeaderBytes);
  igtl_header_convert_byte_order(&raw);
  Header h;
  h.version = raw.version;
  // Random bytes or another protocol (an HTTP request on the port) fail here: OpenIGTLink's
  // header versions are 1 and 2 (OpenIGTLink 3).
  if (raw.version != 1 && raw.version != 2)
    throw bad("not an OpenIGTLink header (version " + std::to_string(raw.version) + ")");
  if (!read_text(raw.name, IGTL_HEADER_TYPE_SIZE, false, h.type) || h.type.empty())
    throw bad("not an OpenIGTLink header (the device type is not text)");
  if (!read_text(raw.device_name, IGTL_HEADER_NAME_SIZE, true, h.device))
    throw bad("not an OpenIGTLink header (the device name of a " + h.type + " is not text)");
  h.body_bytes = raw.body_size;
  h.crc = raw.crc;
  if (h.body_bytes > max_body_bytes)
    throw bad(h.type + " '" + h.device + "' declares a body of " + std::to_string(h.body_bytes) +
              " bytes, more than the limit of " + std::to_string(max_body_bytes) +
              " (--max-message-mb)");
  return h;
}

Content check_body(const Header& h, const uint8_t* body) {
  const uint64_t crc = crc64(const_cast<uint8_t*>(body), h.body_bytes, 0);
  if (crc != h.crc)
    throw bad("bad CRC on " + h.type + " '" + h.device + "' (" + std::to_string(h.body_bytes) +
              " bytes)");
  Content c{0, static_cast<size_t>(h.body_bytes)};
  if (h.version == 1) return c;
  // Header version 2: extended header (its own size, the metadata header's and the metadata's
  // sizes, a message id), then the content, then the metadata header and the metadata.
  const auto inconsistent = [&] {
    return bad(h.type + " '" + h.device + "': header version 2 with an extended header that " +
               "does not fit its " + std::to_string(h.body_bytes) + "-byte body");
  };
  if (h.body_bytes < 12) throw inconsistent();
  const uint64_t extended = big_endian_u16(body), meta_header = big_endian_u16(body + 2),
                 meta = big_endian_u32(body + 4);
  if (extended < 12 || extended + meta_header + meta > h.body_bytes) throw inconsistent();
  c.offset = static_cast<size_t>(extended);
  c.size = static_cast<size_t>(h.body_bytes - extended - meta_header - meta);
  return c;
}

Eigen::Vector3d change_frame(const Eigen::Vector3d& p, Frame frame) {
  return frame == Frame::kLps ? p : Eigen::Vector3d(-p.x(), -p.y(), p.z());
}

Pose read_pose(const std::string& type, const uint8_t* content, size_t size) {
  Pose pose;
  Eigen::Vector3d& p = pose.position;
  Eigen::Vector3d& z = pose.z_axis;
  if (type == "TRANSFORM") {
    // 3x3 rotation column by column, then the translation; big-endian float32.
    if (size != IGTL_TRANSFORM_SIZE)
      throw bad("a TRANSFORM has " + std::to_string(IGTL_TRANSFORM_SIZE) + " bytes of content, " +
                "this one " + std::to_string(size));
    igtl_float32 m[12];
    std::memcpy(m, content, sizeof(m));
    igtl_transform_convert_byte_order(m);
    p = Eigen::Vector3d(m[9], m[10], m[11]);
    z = Eigen::Vector3d(m[6], m[7], m[8]);
  } else if (type == "POSITION") {
    // The position, then none, three or four quaternion components.
    igtl_position pos{};
    pos.quaternion[3] = 1.0f;  // none sent: no rotation
    if (size == IGTL_POSITION_MESSAGE_POSITON_ONLY_SIZE) {
      std::memcpy(&pos, content, size);
      igtl_position_convert_byte_order_position_only(&pos);
    } else if (size == IGTL_POSITION_MESSAGE_WITH_QUATERNION3_SIZE) {
      std::memcpy(&pos, content, size);
      igtl_position_convert_byte_order_quaternion3(&pos);
      // Three components: the fourth (w) follows from a unit quaternion.
      const double v = pos.quaternion[0] * pos.quaternion[0] +
                       pos.quaternion[1] * pos.quaternion[1] +
                       pos.quaternion[2] * pos.quaternion[2];
      pos.quaternion[3] = static_cast<igtl_float32>(std::sqrt(std::max(0.0, 1.0 - v)));
    } else if (size == IGTL_POSITION_MESSAGE_DEFAULT_SIZE) {
      std::memcpy(&pos, content, size);
      igtl_position_convert_byte_order(&pos);
    } else {
      throw bad("a POSITION has 12, 24 or 28 bytes of content, this one " + std::to_string(size));
    }
    p = Eigen::Vector3d(pos.position[0], pos.position[1], pos.position[2]);
    // OpenIGTLink's quaternion is (x, y, z, w); its third column is where it turns z.
    const double x = pos.quaternion[0], y = pos.quaternion[1], qz = pos.quaternion[2],
                 w = pos.quaternion[3];
    z = Eigen::Vector3d(2 * (x * qz + w * y), 2 * (y * qz - w * x), 1 - 2 * (x * x + y * y));
  } else {
    throw bad(type + " carries no position");
  }
  if (!p.allFinite()) throw bad("a " + type + " whose position is not finite");
  if (!z.allFinite() || !(z.norm() > 1e-6)) throw bad("a " + type + " whose rotation is not one");
  z.normalize();
  return pose;
}

Eigen::Vector3d read_position(const std::string& type, const uint8_t* content, size_t size) {
  return read_pose(type, content, size).position;
}

Packed pack_transform(const std::string& device, const Eigen::Vector3d& t) {
  igtl::TransformMessage::Pointer message = igtl::TransformMessage::New();
  message->SetDeviceName(device.c_str());
  igtl::Matrix4x4 m;
  igtl::IdentityMatrix(m);
  for (int i = 0; i < 3; ++i) m[i][3] = static_cast<float>(t[i]);
  message->SetMatrix(m);
  stamp_now(*message);
  return packed_bytes(*message);
}

Packed pack_string(const std::string& device, const std::string& text) {
  igtl::StringMessage::Pointer message = igtl::StringMessage::New();
  message->SetDeviceName(device.c_str());
  message->SetEncoding(3);  // IANA's MIBenum for US-ASCII, OpenIGTLink's default
  message->SetString(text.c_str());
  stamp_now(*message);
  return packed_bytes(*message);
}

std::string read_string(const uint8_t* content, size_t size) {
  if (size < IGTL_STRING_HEADER_SIZE)
    throw bad("a STRING has at least 4 bytes of content, this one " + std::to_string(size));
  igtl_string_header h;
  std::memcpy(&h, content, IGTL_STRING_HEADER_SIZE);
  igtl_string_convert_byte_order(&h);
  const size_t encoding = h.encoding, length = h.length;
  if (length != size - IGTL_STRING_HEADER_SIZE)
    throw bad("a STRING says it holds " + std::to_string(length) + " bytes of text, its content " +
              std::to_string(size - IGTL_STRING_HEADER_SIZE));
  // US-ASCII (3) is what lamina serve reads; UTF-8 (106) is read when its bytes are ASCII.
  if (encoding != 3 && encoding != 106)
    throw bad("a STRING in encoding " + std::to_string(encoding) + " (US-ASCII, 3, is read)");
  std::string text(reinterpret_cast<const char*>(content + IGTL_STRING_HEADER_SIZE), length);
  for (const char c : text)
    if (c < 0x20 || c > 0x7e) throw bad("a STRING whose text is not printable US-ASCII");
  return text;
}

namespace {

void put_u32(uint8_t* at, uint32_t v) {
  at[0] = static_cast<uint8_t>(v >> 24);
  at[1] = static_cast<uint8_t>(v >> 16);
  at[2] = static_cast<uint8_t>(v >> 8);
  at[3] = static_cast<uint8_t>(v);
}

void put_u64(uint8_t* at, uint64_t v) {
  put_u32(at, static_cast<uint32_t>(v >> 32));
  put_u32(at + 4, static_cast<uint32_t>(v));
}

uint64_t timestamp_now() {
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                      std::chrono::system_clock::now().time_since_epoch())
                      .count();
  const auto seconds = static_cast<uint64_t>(ns / 1000000000);
  return seconds << 32 | igtl_nanosec_to_frac(static_cast<igtl_uint32>(ns % 1000000000));
}

// POLYDATA's body: a header of ten counts and sizes, the points (float32 x, y, z), then the
// vertices, lines, polygons and strips as (n, i1 ... in) lists, then attributes; only points and
// polygons here. The header's time stamp (offset 34), body size (42) and CRC (50) follow the
// version (2 bytes), type (12) and device name (20).
constexpr size_t kTimestampAt = 34, kBodySizeAt = 42, kCrcAt = 50;
constexpr size_t kPolyHeaderBytes = 10 * 4;

}  // namespace

PolyDataPacker::PolyDataPacker(std::string device, const Eigen::MatrixX3i& F, int32_t points)
    : device_(std::move(device)), points_(points) {
  const auto triangles = static_cast<size_t>(F.rows());
  const size_t points_bytes = static_cast<size_t>(points) * 12, polygon_bytes = triangles * 16;
  const size_t body = kPolyHeaderBytes + points_bytes + polygon_bytes;
  message_ = std::make_shared<std::vector<uint8_t>>(kHeaderBytes + body, 0);
  uint8_t* m = message_->data();
  m[1] = 1;  // header version 1
  std::memcpy(m + 2, "POLYDATA", 8);
  std::memcpy(m + 14, device_.data(), std::min<size_t>(device_.size(), IGTL_HEADER_NAME_SIZE));
  put_u64(m + kBodySizeAt, body);
  const uint32_t counts[10] = {
      static_cast<uint32_t>(points),        0, 0, 0, 0, static_cast<uint32_t>(triangles),
      static_cast<uint32_t>(polygon_bytes), 0, 0, 0};
  for (int i = 0; i < 10; ++i) put_u32(m + kHeaderBytes + 4 * i, counts[i]);
  uint8_t* cell = m + kHeaderBytes + kPolyHeaderBytes + points_bytes;
  for (size_t f = 0; f < triangles; ++f, cell += 16) {
    put_u32(cell, 3);
    for (int c = 0; c < 3; ++c)
      put_u32(cell + 4 + 4 * c, static_cast<uint32_t>(F(static_cast<Eigen::Index>(f), c)));
  }
}

Packed PolyDataPacker::pack(const Eigen::Ref<const Eigen::MatrixX3d>& points, Frame frame,
                            uint64_t timestamp) {
  assert(points.rows() == points_);
  // A client still sending the last message keeps it; this one starts from a copy of the layout.
  if (message_.use_count() > 1) message_ = std::make_shared<std::vector<uint8_t>>(*message_);
  uint8_t* m = message_->data();
  const float sign = frame == Frame::kRas ? -1.0f : 1.0f;  // RAS: x and y change sign
  uint8_t* at = m + kHeaderBytes + kPolyHeaderBytes;
  for (int32_t i = 0; i < points_; ++i)
    for (int c = 0; c < 3; ++c, at += 4) {
      const float v = static_cast<float>(points(i, c)) * (c < 2 ? sign : 1.0f);
      uint32_t bits;
      std::memcpy(&bits, &v, 4);
      put_u32(at, bits);
    }
  put_u64(m + kTimestampAt, timestamp != 0 ? timestamp : timestamp_now());
  put_u64(m + kCrcAt, crc64(m + kHeaderBytes, message_->size() - kHeaderBytes, 0));
  return message_;
}

}  // namespace lamina::net::igtlink
