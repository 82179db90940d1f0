// The server's own POLYDATA packing (laid out once, points rewritten in place) against the
// OpenIGTLink library's igtl::PolyDataMessage: the same bytes, header and CRC included.
#include "igtl_wire.h"

#include <gtest/gtest.h>
#include <igtlPolyDataMessage.h>
#include <igtlPositionMessage.h>
#include <igtlStringMessage.h>
#include <igtlTimeStamp.h>
#include <igtlTransformMessage.h>
#include <igtl_util.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "lamina/core/error.h"

namespace lamina::test {
namespace {

constexpr uint32_t kSeconds = 1700000000, kNanoseconds = 123456789;

std::vector<uint8_t> library_bytes(const std::string& device, const Eigen::MatrixX3i& F,
                                   const Eigen::MatrixX3d& P) {
  igtl::PolyDataMessage::Pointer m = igtl::PolyDataMessage::New();
  m->SetDeviceName(device.c_str());
  igtl::PolyDataPointArray::Pointer points = igtl::PolyDataPointArray::New();
  points->SetNumberOfPoints(static_cast<int>(P.rows()));
  for (int i = 0; i < P.rows(); ++i)
    points->SetPoint(i, static_cast<float>(P(i, 0)), static_cast<float>(P(i, 1)),
                     static_cast<float>(P(i, 2)));
  igtl::PolyDataCellArray::Pointer polygons = igtl::PolyDataCellArray::New();
  for (int f = 0; f < F.rows(); ++f) {
    igtlUint32 cell[3] = {static_cast<igtlUint32>(F(f, 0)), static_cast<igtlUint32>(F(f, 1)),
                          static_cast<igtlUint32>(F(f, 2))};
    polygons->AddCell(3, cell);
  }
  m->SetPoints(points);
  m->SetPolygons(polygons);
  igtl::TimeStamp::Pointer t = igtl::TimeStamp::New();
  t->SetTime(kSeconds, kNanoseconds);
  m->SetTimeStamp(t);
  m->Pack();
  const auto* bytes = static_cast<const uint8_t*>(m->GetPackPointer());
  return {bytes, bytes + m->GetPackSize()};
}

// Where two messages first differ ("none" if they are equal), for a failure's message.
std::string first_difference(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i)
    if (a[i] != b[i])
      return "byte " + std::to_string(i) + ": " + std::to_string(a[i]) + " vs " +
             std::to_string(b[i]);
  return a.size() == b.size()
             ? "none"
             : std::to_string(a.size()) + " vs " + std::to_string(b.size()) + " bytes";
}

TEST(Serve, ThePolyDataPackerWritesTheLibrarysBytesAndReusesItsBuffer) {
  Eigen::MatrixX3i F(3, 3);
  F << 0, 1, 2, 0, 2, 3, 3, 2, 4;
  Eigen::MatrixX3d P = Eigen::MatrixX3d::Random(5, 3) * 100.0;
  // The library keeps seconds and nanoseconds; the wire has seconds and 2^-32 s.
  const uint64_t timestamp = (uint64_t{kSeconds} << 32) | igtl_nanosec_to_frac(kNanoseconds);
  net::igtlink::PolyDataPacker packer("display_skin", F, 5);
  // RAS on the wire: the library is given the points already changed.
  Eigen::MatrixX3d ras = P;
  ras.leftCols(2) *= -1.0;
  net::igtlink::Packed first = packer.pack(P, net::igtlink::Frame::kRas, timestamp);
  EXPECT_EQ(first_difference(*first, library_bytes("display_skin", F, ras)), "none");
  EXPECT_EQ(packer.message_bytes(), first->size());
  const void* buffer = first->data();

  // Still held (a client is sending it): the next message is a new buffer, the first unchanged.
  P.array() += 1.0;
  net::igtlink::Packed second = packer.pack(P, net::igtlink::Frame::kLps, timestamp);
  EXPECT_NE(second->data(), buffer);
  EXPECT_EQ(first_difference(*first, library_bytes("display_skin", F, ras)), "none");
  EXPECT_EQ(first_difference(*second, library_bytes("display_skin", F, P)), "none");
  // Released: the next message is written in place.
  const void* reused = second->data();
  first.reset();
  second.reset();
  P.array() += 1.0;
  const net::igtlink::Packed third = packer.pack(P, net::igtlink::Frame::kLps, timestamp);
  EXPECT_EQ(third->data(), reused);
  EXPECT_EQ(first_difference(*third, library_bytes("display_skin", F, P)), "none");
}

}  // namespace
}  // namespace lamina::test

namespace lamina::test {
namespace {

// The body (content) of a message the library packs.
std::vector<uint8_t> content_of(igtl::MessageBase& m) {
  m.Pack();
  const auto* bytes = static_cast<const uint8_t*>(m.GetPackBodyPointer());
  return {bytes, bytes + m.GetPackBodySize()};
}

// A scalpel's pose: a TRANSFORM's third rotation column is its blade's axis, a POSITION's
// quaternion turns z to it; a rotation that turns z to nothing is refused (its client dropped).
TEST(Serve, APoseGivesThePositionAndTheBladesAxis) {
  igtl::TransformMessage::Pointer t = igtl::TransformMessage::New();
  igtl::Matrix4x4 m;
  igtl::IdentityMatrix(m);
  // A quarter turn about x: z goes to -y.
  m[1][1] = 0, m[1][2] = -1, m[2][1] = 1, m[2][2] = 0;
  m[0][3] = 1, m[1][3] = 2, m[2][3] = 3;
  t->SetMatrix(m);
  std::vector<uint8_t> c = content_of(*t);
  net::igtlink::Pose pose = net::igtlink::read_pose("TRANSFORM", c.data(), c.size());
  EXPECT_EQ(pose.position, Eigen::Vector3d(1, 2, 3));
  EXPECT_LT((pose.z_axis - Eigen::Vector3d(0, -1, 0)).norm(), 1e-6) << pose.z_axis.transpose();

  igtl::PositionMessage::Pointer p = igtl::PositionMessage::New();
  p->SetPosition(4.0f, 5.0f, 6.0f);
  const float s = std::sqrt(0.5f);
  p->SetQuaternion(s, 0.0f, 0.0f, s);  // the same quarter turn about x, (x, y, z, w)
  c = content_of(*p);
  pose = net::igtlink::read_pose("POSITION", c.data(), c.size());
  EXPECT_EQ(pose.position, Eigen::Vector3d(4, 5, 6));
  EXPECT_LT((pose.z_axis - Eigen::Vector3d(0, -1, 0)).norm(), 1e-6) << pose.z_axis.transpose();

  igtl::Matrix4x4 flat;
  igtl::IdentityMatrix(flat);
  flat[0][2] = flat[1][2] = flat[2][2] = 0;  // no z axis
  t->SetMatrix(flat);
  c = content_of(*t);
  try {
    net::igtlink::read_pose("TRANSFORM", c.data(), c.size());
    ADD_FAILURE() << "a rotation that is none was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("whose rotation is not one"), std::string::npos);
  }
}

// A STRING's text as the library packs it; a length that disagrees with the content, or text
// that is not printable ASCII, is refused (its client dropped).
TEST(Serve, AStringsTextIsReadAndAMalformedOneRefused) {
  igtl::StringMessage::Pointer m = igtl::StringMessage::New();
  m->SetString("1000");
  std::vector<uint8_t> c = content_of(*m);
  EXPECT_EQ(net::igtlink::read_string(c.data(), c.size()), "1000");
  const auto refused = [](std::vector<uint8_t> bytes, const std::string& why) {
    try {
      net::igtlink::read_string(bytes.data(), bytes.size());
      ADD_FAILURE() << "read: " << why;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  };
  std::vector<uint8_t> longer = c;
  longer[3] = 9;  // says 9 bytes, holds 4
  refused(longer, "says it holds 9 bytes");
  std::vector<uint8_t> control = c;
  control[5] = '\n';
  refused(control, "not printable");
  refused({0, 3}, "at least 4 bytes");
}

}  // namespace
}  // namespace lamina::test
