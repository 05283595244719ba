// sensor_msgs/PointCloud2 decoding without ROS (pointcloud2.hpp, ros1_messages.hpp): the layouts drivers publish,
// and layouts whose size fields lie.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "tsdf_mcl/core/little_endian.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/limits.hpp"
#include "tsdf_mcl/io/pointcloud2.hpp"
#include "tsdf_mcl/io/ros1_messages.hpp"

namespace tsdf_mcl {
namespace {

// Writes values into a byte buffer at given offsets, little- or big-endian.
class Bytes {
 public:
  Bytes(std::size_t size, bool big_endian = false) : data(size, 0xAB), big_(big_endian) {}
  template <typename T>
  void put(std::size_t offset, T value) {
    if (big_ == io::kHostIsLittleEndian) value = io::byte_swapped(value);
    std::memcpy(data.data() + offset, &value, sizeof(T));
  }
  std::vector<std::uint8_t> data;

 private:
  bool big_;
};

PointCloud decode(const PointCloud2Layout& l, const std::vector<std::uint8_t>& data,
                  PointCloud2Stats* stats = nullptr) {
  return decode_pointcloud2(l, data.data(), data.size(), stats, "test cloud");
}

// The error message of decoding, "" if it decodes.
std::string error_of(const PointCloud2Layout& l, const std::vector<std::uint8_t>& data) {
  try {
    decode(l, data);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

PointCloud2Layout xyz_float32(std::uint32_t width, std::uint32_t height = 1) {
  PointCloud2Layout l;
  l.width = width;
  l.height = height;
  l.fields = {{"x", 0, kPointFloat32, 1}, {"y", 4, kPointFloat32, 1}, {"z", 8, kPointFloat32, 1}};
  l.point_step = 12;
  l.row_step = 12 * width;
  return l;
}

TEST(PointCloud2, FieldCountZeroOrBeyondThePointIsAnError) {
  PointCloud2Layout l = xyz_float32(2);
  const std::vector<std::uint8_t> data(24, 0);
  l.fields[1].count = 0;
  EXPECT_NE(error_of(l, data).find("field 'y' has count 0"), std::string::npos) << error_of(l, data);
  l.fields[1].count = 1000000000;
  EXPECT_NE(error_of(l, data).find("field 'y' (1000000000 x FLOAT32 at offset 4) does not fit in point_step 12"),
            std::string::npos)
      << error_of(l, data);
  l.fields[1].count = 1;
  EXPECT_EQ(error_of(l, data), "");
}

TEST(PointCloud2, XyzFloat32) {
  const PointCloud2Layout l = xyz_float32(3);
  Bytes b(36);
  for (int i = 0; i < 3; ++i) {
    b.put<float>(12 * i, 1.0f + i);
    b.put<float>(12 * i + 4, -2.0f * i);
    b.put<float>(12 * i + 8, 0.5f);
  }
  PointCloud2Stats stats;
  const PointCloud c = decode(l, b.data, &stats);
  ASSERT_EQ(c.size(), 3u);
  EXPECT_TRUE(c.intensity.empty());
  EXPECT_EQ(c.points[2], Eigen::Vector3f(3.0f, -4.0f, 0.5f));
  EXPECT_EQ(stats.points, 3u);
  EXPECT_EQ(stats.dropped_non_finite, 0u);
}

TEST(PointCloud2, Float64Coordinates) {
  PointCloud2Layout l;
  l.width = 2;
  l.height = 1;
  l.fields = {{"x", 0, kPointFloat64, 1}, {"y", 8, kPointFloat64, 1}, {"z", 16, kPointFloat64, 1}};
  l.point_step = 24;
  l.row_step = 48;
  Bytes b(48);
  b.put<double>(0, 1.25);
  b.put<double>(8, -3.5);
  b.put<double>(16, 100.125);
  b.put<double>(24, 1e300);  // beyond float: not finite as a float, dropped
  b.put<double>(32, 0.0);
  b.put<double>(40, 0.0);
  PointCloud2Stats stats;
  const PointCloud c = decode(l, b.data, &stats);
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c.points[0], Eigen::Vector3f(1.25f, -3.5f, 100.125f));
  EXPECT_EQ(stats.dropped_non_finite, 1u);
}

// An Ouster-like point: intensity first, x unaligned, z float64, ring and t among them; unknown fields ignored.
TEST(PointCloud2, ExtraFieldsAtOddOffsets) {
  PointCloud2Layout l;
  l.width = 2;
  l.height = 1;
  l.fields = {{"intensity", 0, kPointUint16, 1},    {"ring", 2, kPointUint16, 1},  {"x", 5, kPointFloat32, 1},
              {"y", 9, kPointFloat32, 1},           {"t", 13, kPointUint32, 1},    {"z", 17, kPointFloat64, 1},
              {"reflectivity", 25, kPointUint8, 1}, {"time", 26, kPointFloat32, 1}};
  l.point_step = 31;
  l.row_step = 62;
  Bytes b(62);
  for (int i = 0; i < 2; ++i) {
    const std::size_t o = 31 * i;
    b.put<std::uint16_t>(o, static_cast<std::uint16_t>(700 + i));
    b.put<std::uint16_t>(o + 2, 5);
    b.put<float>(o + 5, 10.0f + i);
    b.put<float>(o + 9, 20.0f);
    b.put<std::uint32_t>(o + 13, 123456);
    b.put<double>(o + 17, -1.5);
  }
  const PointCloud c = decode(l, b.data);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.points[1], Eigen::Vector3f(11.0f, 20.0f, -1.5f));
  ASSERT_EQ(c.intensity.size(), 2u);
  EXPECT_EQ(c.intensity[0], 700.0f);
  EXPECT_EQ(c.intensity[1], 701.0f);
}

// An organized cloud (2 rows of 3) with NaN and Inf marking missing returns: dropped and counted, the rest in row
// order.
TEST(PointCloud2, OrganizedWithNaNs) {
  const PointCloud2Layout l = xyz_float32(3, 2);
  Bytes b(72);
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const float xs[6] = {1, nan, 3, 4, 5, 6};
  const float zs[6] = {0, 0, 0, inf, 0, 0};
  for (int i = 0; i < 6; ++i) {
    b.put<float>(12 * i, xs[i]);
    b.put<float>(12 * i + 4, static_cast<float>(i));
    b.put<float>(12 * i + 8, zs[i]);
  }
  PointCloud2Stats stats;
  const PointCloud c = decode(l, b.data, &stats);
  ASSERT_EQ(c.size(), 4u);
  EXPECT_EQ(c.points[0].x(), 1.0f);
  EXPECT_EQ(c.points[1].x(), 3.0f);
  EXPECT_EQ(c.points[2].x(), 5.0f);
  EXPECT_EQ(c.points[3].x(), 6.0f);
  EXPECT_EQ(stats.points, 6u);
  EXPECT_EQ(stats.dropped_non_finite, 2u);
}

TEST(PointCloud2, BigEndian) {
  PointCloud2Layout l = xyz_float32(2);
  l.fields.push_back({"intensity", 12, kPointFloat64, 1});
  l.point_step = 20;
  l.row_step = 40;
  l.is_bigendian = true;
  Bytes b(40, /*big_endian=*/true);
  b.put<float>(0, 1.5f);
  b.put<float>(4, -2.25f);
  b.put<float>(8, 1e-3f);
  b.put<double>(12, 42.0);
  b.put<float>(20, 7.0f);
  b.put<float>(24, 8.0f);
  b.put<float>(28, 9.0f);
  b.put<double>(32, 0.5);
  const PointCloud c = decode(l, b.data);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.points[0], Eigen::Vector3f(1.5f, -2.25f, 1e-3f));
  EXPECT_EQ(c.points[1], Eigen::Vector3f(7.0f, 8.0f, 9.0f));
  EXPECT_EQ(c.intensity[0], 42.0f);
  EXPECT_EQ(c.intensity[1], 0.5f);
}

// Rows padded to row_step: the padding is skipped, and the last row needs no padding after it.
TEST(PointCloud2, RowPadding) {
  PointCloud2Layout l = xyz_float32(2, 3);
  l.row_step = 2 * 12 + 7;
  Bytes b(2 * l.row_step + 24);
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 2; ++col) {
      const std::size_t o = row * l.row_step + col * 12;
      b.put<float>(o, static_cast<float>(10 * row + col));
      b.put<float>(o + 4, 0.0f);
      b.put<float>(o + 8, 0.0f);
    }
  }
  const PointCloud c = decode(l, b.data);
  ASSERT_EQ(c.size(), 6u);
  for (int k = 0; k < 6; ++k) EXPECT_EQ(c.points[k].x(), static_cast<float>(10 * (k / 2) + k % 2));
}

TEST(PointCloud2, EmptyCloudDecodesToNoPoints) {
  PointCloud2Stats stats;
  EXPECT_TRUE(decode(xyz_float32(0, 1), {}, &stats).empty());
  EXPECT_EQ(stats.points, 0u);
}

// Every lie of a size field is one clear sentence, before anything is read: decoding 120 bytes with layout `l`
// fails with one line that names the cloud and holds `words`.
void expect_hostile(const PointCloud2Layout& l, const std::string& words) {
  const std::vector<std::uint8_t> data(120, 0);
  const std::string e = error_of(l, data);
  EXPECT_NE(e.find(words), std::string::npos) << "'" << e << "' lacks '" << words << "'";
  EXPECT_EQ(e.rfind("test cloud: ", 0), 0u) << e;
  EXPECT_EQ(e.find('\n'), std::string::npos) << e;
}

// Sizes and counts that lie: data too short, rows overlapping, more points than the limit.
TEST(PointCloud2, HostileSizesAreErrors) {
  {
    PointCloud2Layout l = xyz_float32(11);  // 132 bytes needed, 120 there
    expect_hostile(l, "data holds 120 bytes");
  }
  {
    PointCloud2Layout l = xyz_float32(2, 3);
    l.row_step = 60;  // rows 60 bytes apart: 2 * 60 + 24 = 144 > 120
    expect_hostile(l, "need 144");
  }
  for (const std::uint32_t height : {2u, 1u}) {
    PointCloud2Layout l = xyz_float32(3, height);
    l.row_step = 20;  // less than a row of points: a corrupt message, also where a single row does not need it
    expect_hostile(l, "row_step 20 is less than width 3 * point_step 12");
  }
  {
    PointCloud2Layout l = xyz_float32(0xFFFFFFFFu, 0xFFFFFFFFu);  // 2^64 - 2^33 + 1 points
    expect_hostile(l, "more than the limit");
  }
  {
    PointCloud2Layout l = xyz_float32(1u << 24, 2);
    expect_hostile(l, "more than the limit of 16777216 points");
  }
  {
    PointCloud2Layout l = xyz_float32(5);
    l.point_step = 0xFFFFFFFFu;
    l.row_step = 0xFFFFFFFFu;
    expect_hostile(l, "row_step 4294967295 is less than width 5 * point_step 4294967295");
    l.width = 1;  // rows of one huge point, 2^32 - 1 bytes apart
    l.height = 2;
    expect_hostile(l, "data holds 120 bytes");
  }
}

// Fields placed outside the point, or no point at all.
TEST(PointCloud2, HostileFieldPlacesAreErrors) {
  {
    PointCloud2Layout l = xyz_float32(1);
    l.fields[2].offset = 10;  // z reaches past point_step 12
    expect_hostile(l, "field 'z' (FLOAT32 at offset 10) does not fit in point_step 12");
  }
  {
    PointCloud2Layout l = xyz_float32(1);
    l.fields[1].offset = 0xFFFFFFFEu;
    expect_hostile(l, "field 'y'");
  }
  {
    PointCloud2Layout l = xyz_float32(1);
    l.point_step = 0;
    expect_hostile(l, "point_step 0");
  }
}

// Fields missing, of the wrong or an unknown type, or twice.
TEST(PointCloud2, HostileFieldListsAreErrors) {
  {
    PointCloud2Layout l = xyz_float32(1);
    l.fields.pop_back();
    l.fields.push_back({"intensity", 8, kPointFloat32, 1});
    expect_hostile(l, "has no field z (its fields: x y intensity)");
  }
  {
    PointCloud2Layout l = xyz_float32(1);
    l.fields.clear();
    expect_hostile(l, "has no field x, y, z (its fields: none)");
  }
  {
    PointCloud2Layout l = xyz_float32(1);
    l.fields[0].datatype = kPointInt16;
    expect_hostile(l, "field 'x' is INT16 (x, y and z must be FLOAT32 or FLOAT64)");
  }
  {
    PointCloud2Layout l = xyz_float32(1);
    l.fields[0].datatype = 9;
    expect_hostile(l, "datatype 9");
  }
  {
    PointCloud2Layout l = xyz_float32(1);
    l.fields.push_back({"x", 0, kPointFloat32, 1});
    expect_hostile(l, "two fields named 'x'");
  }
}

TEST(PointCloud2, EncodeDecodeRoundTripWithRings) {
  PointCloud cloud;
  cloud.points = {{1, 2, 3}, {-4.5f, 0, 1e-6f}, {7, 8, 9}};
  cloud.intensity = {0.25f, 0.5f, 1.0f};
  const std::vector<std::uint16_t> rings = {0, 15, 7};
  const EncodedPointCloud2 e = encode_pointcloud2(cloud, &rings);
  EXPECT_EQ(e.layout.point_step, 18u);
  ASSERT_EQ(e.layout.fields.size(), 5u);
  EXPECT_EQ(e.layout.fields[4].name, "ring");
  EXPECT_EQ(e.layout.fields[4].datatype, kPointUint16);
  const PointCloud back = decode(e.layout, e.data);
  EXPECT_EQ(back.points, cloud.points);
  EXPECT_EQ(back.intensity, cloud.intensity);
  // The ring field reads back as written.
  EXPECT_EQ(io::load<std::uint16_t>(e.data.data() + 18 + 16, true), 15);
  // Without rings: x y z intensity only, intensity 0 where the cloud has none.
  cloud.intensity.clear();
  const EncodedPointCloud2 plain = encode_pointcloud2(cloud);
  EXPECT_EQ(plain.layout.point_step, 16u);
  EXPECT_EQ(decode(plain.layout, plain.data).intensity, std::vector<float>(3, 0.0f));
}

// The serialized message: header, layout and data; truncation anywhere and trailing bytes are errors.
TEST(PointCloud2, SerializedMessage) {
  PointCloud cloud;
  cloud.points = {{1, 2, 3}, {4, 5, 6}};
  const EncodedPointCloud2 e = encode_pointcloud2(cloud);
  ros1::Header h;
  h.seq = 7;
  h.sec = 1630577758;
  h.nsec = 569490000;
  h.frame_id = "os_lidar";
  const std::vector<std::uint8_t> bytes = ros1::encode_pointcloud2_message(h, e.layout, e.data);
  const ros1::PointCloud2Message m = ros1::decode_pointcloud2_message(bytes.data(), bytes.size(), "msg");
  EXPECT_EQ(m.header.frame_id, "os_lidar");
  EXPECT_EQ(m.header.seq, 7u);
  EXPECT_DOUBLE_EQ(m.header.stamp(), 1630577758.56949);
  EXPECT_EQ(m.layout.fields.size(), 4u);
  EXPECT_EQ(m.data_size, e.data.size());
  EXPECT_EQ(decode_pointcloud2(m.layout, bytes.data() + m.data_offset, m.data_size).points, cloud.points);
  EXPECT_EQ(ros1::decode_header(bytes.data(), bytes.size(), "msg").frame_id, "os_lidar");
  for (std::size_t cut = 0; cut < bytes.size(); ++cut) {
    EXPECT_THROW(ros1::decode_pointcloud2_message(bytes.data(), cut, "msg"), Error) << cut;
  }
  std::vector<std::uint8_t> longer = bytes;
  longer.push_back(0);
  try {
    ros1::decode_pointcloud2_message(longer.data(), longer.size(), "msg");
    FAIL();
  } catch (const Error& err) {
    EXPECT_NE(std::string(err.what()).find("1 bytes left over"), std::string::npos) << err.what();
  }
  // A data length of 4 GiB in a 100-byte message: refused, nothing allocated.
  std::vector<std::uint8_t> lying = bytes;
  const std::size_t length_at = m.data_offset - 4;
  const std::uint32_t huge = 0xFFFFFFF0u;
  std::memcpy(lying.data() + length_at, &huge, 4);
  EXPECT_THROW(ros1::decode_pointcloud2_message(lying.data(), lying.size(), "msg"), Error);
}

}  // namespace
}  // namespace tsdf_mcl
