#include "igtl_wire.h"

#include <igtlPolyDataMessage.h>
#include <igtlTimeStamp.h>
#include <igtlTransformMessage.h>
#include <igtl_header.h>
#include <igtl_position.h>
#include <igtl_transform.h>
#include <igtl_util.h>

#include <cmath>
#include <cstring>

#include "lamina/core/error.h"

namespace lamina::cli::net {
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

Eigen::Vector3d read_position(const std::string& type, const uint8_t* content, size_t size) {
  Eigen::Vector3d p;
  if (type == "TRANSFORM") {
    // 3x3 rotation column by column, then the translation; big-endian float32.
    if (size != IGTL_TRANSFORM_SIZE)
      throw bad("a TRANSFORM has " + std::to_string(IGTL_TRANSFORM_SIZE) + " bytes of content, " +
                "this one " + std::to_string(size));
    igtl_float32 m[12];
    std::memcpy(m, content, sizeof(m));
    igtl_transform_convert_byte_order(m);
    p = Eigen::Vector3d(m[9], m[10], m[11]);
  } else if (type == "POSITION") {
    // The position, then none, three or four quaternion components.
    igtl_position pos{};
    if (size == IGTL_POSITION_MESSAGE_POSITON_ONLY_SIZE) {
      std::memcpy(&pos, content, size);
      igtl_position_convert_byte_order_position_only(&pos);
    } else if (size == IGTL_POSITION_MESSAGE_WITH_QUATERNION3_SIZE) {
      std::memcpy(&pos, content, size);
      igtl_position_convert_byte_order_quaternion3(&pos);
    } else if (size == IGTL_POSITION_MESSAGE_DEFAULT_SIZE) {
      std::memcpy(&pos, content, size);
      igtl_position_convert_byte_order(&pos);
    } else {
      throw bad("a POSITION has 12, 24 or 28 bytes of content, this one " + std::to_string(size));
    }
    p = Eigen::Vector3d(pos.position[0], pos.position[1], pos.position[2]);
  } else {
    throw bad(type + " carries no position");
  }
  if (!p.allFinite()) throw bad("a " + type + " whose position is not finite");
  return p;
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

struct PolyDataPacker::Message {
  igtl::PolyDataMessage::Pointer message;
  igtl::PolyDataPointArray::Pointer points;
};

PolyDataPacker::PolyDataPacker(std::string device, const Eigen::MatrixX3i& F, int32_t points)
    : device_(std::move(device)), points_(points), message_(std::make_unique<Message>()) {
  message_->message = igtl::PolyDataMessage::New();
  message_->message->SetDeviceName(device_.c_str());
  message_->points = igtl::PolyDataPointArray::New();
  message_->points->SetNumberOfPoints(points);
  igtl::PolyDataCellArray::Pointer polygons = igtl::PolyDataCellArray::New();
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    igtlUint32 cell[3] = {static_cast<igtlUint32>(F(f, 0)), static_cast<igtlUint32>(F(f, 1)),
                          static_cast<igtlUint32>(F(f, 2))};
    polygons->AddCell(3, cell);
  }
  message_->message->SetPoints(message_->points);
  message_->message->SetPolygons(polygons);
}

PolyDataPacker::~PolyDataPacker() = default;
PolyDataPacker::PolyDataPacker(PolyDataPacker&&) noexcept = default;
PolyDataPacker& PolyDataPacker::operator=(PolyDataPacker&&) noexcept = default;

Packed PolyDataPacker::pack(const Eigen::MatrixX3d& points) {
  for (int32_t i = 0; i < points_; ++i)
    message_->points->SetPoint(i, static_cast<float>(points(i, 0)),
                               static_cast<float>(points(i, 1)), static_cast<float>(points(i, 2)));
  stamp_now(*message_->message);
  return packed_bytes(*message_->message);
}

}  // namespace lamina::cli::net
