// ROS 2 messages in CDR (include/tsdf_mcl/io/ros2_messages.hpp): the bytes another serializer writes
// (@foxglove/rosmsg2-serialization and @foxglove/cdr, pinned below as hex) decode, the encoders write the same
// bytes, every message round-trips in both byte orders, and hostile messages are one-sentence errors.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "error_message.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/pointcloud2.hpp"
#include "tsdf_mcl/io/ros2_messages.hpp"

namespace tsdf_mcl {
namespace {

std::vector<std::uint8_t> from_hex(const std::string& hex) {
  std::vector<std::uint8_t> out;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2)
    out.push_back(static_cast<std::uint8_t>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  return out;
}

using test::error_of;

Pose pose_xyz_q(double x, double y, double z, const Eigen::Quaterniond& q) {
  return msg::pose_of({x, y, z}, q.normalized());
}

// geometry_msgs/PoseStamped {stamp 12 s 500 ns, "map", position (1, -2, 0.5), orientation (0, 0, 0.6, 0.8)} as
// @foxglove/rosmsg2-serialization writes it (CDR_LE).
const char* const kForeignPoseStamped =
    "000100000c000000f4010000040000006d617000000000000000f03f00000000000000c0000000000000e03f0000000000000000000000"
    "0000000000333333333333e33f9a9999999999e93f";
// tf2_msgs/TFMessage {stamp -3 s 7 ns, odom -> base_link, translation (1, 2, 3), rotation (0, 0, 0.6, 0.8)} in
// big-endian CDR as @foxglove/cdr's CdrWriter writes it (CDR_BE).
const char* const kForeignTfBigEndian =
    "0000000000000001fffffffd00000007000000056f646f6d000000000000000a626173655f6c696e6b0000003ff00000000000004000"
    "0000000000004008000000000000000000000000000000000000000000003fe33333333333333fe999999999999a";

TEST(Ros2Messages, DecodesWhatAnotherSerializerWrites) {
  const std::vector<std::uint8_t> pose_bytes = from_hex(kForeignPoseStamped);
  const msg::PoseMessage p = ros2::decode_pose_stamped(pose_bytes.data(), pose_bytes.size(), "pose");
  EXPECT_EQ(p.header.sec, 12);
  EXPECT_EQ(p.header.nsec, 500u);
  EXPECT_EQ(p.header.frame_id, "map");
  const Pose expected = pose_xyz_q(1, -2, 0.5, Eigen::Quaterniond(0.8, 0, 0, 0.6));
  EXPECT_LT((p.pose.matrix() - expected.matrix()).cwiseAbs().maxCoeff(), 1e-12);
  // The encoder writes the very same bytes.
  EXPECT_EQ(ros2::encode_pose_stamped(p), pose_bytes);

  const std::vector<std::uint8_t> tf_bytes = from_hex(kForeignTfBigEndian);
  const std::vector<msg::TransformStamped> tf = ros2::decode_tf_message(tf_bytes.data(), tf_bytes.size(), "tf");
  ASSERT_EQ(tf.size(), 1u);
  EXPECT_EQ(tf[0].header.sec, -3);  // builtin_interfaces/Time's seconds are signed
  EXPECT_EQ(tf[0].header.nsec, 7u);
  EXPECT_EQ(tf[0].header.frame_id, "odom");
  EXPECT_EQ(tf[0].child_frame_id, "base_link");
  EXPECT_LT((tf[0].transform.matrix() - pose_xyz_q(1, 2, 3, Eigen::Quaterniond(0.8, 0, 0, 0.6)).matrix())
                .cwiseAbs()
                .maxCoeff(),
            1e-12);
  EXPECT_EQ(ros2::encode_tf_message(tf, /*big_endian=*/true), tf_bytes);
}

TEST(Ros2Messages, EveryMessageRoundTripsInBothByteOrders) {
  for (const bool big : {false, true}) {
    msg::Header h = msg::stamp_of(1234.5678);
    h.frame_id = "os_lidar";
    PointCloud cloud;
    cloud.points = {{1.f, 2.f, 3.f}, {-4.f, 5.5f, 6.f}};
    cloud.intensity = {10.f, 20.f};
    const EncodedPointCloud2 encoded = encode_pointcloud2(cloud);
    const std::vector<std::uint8_t> pc = ros2::encode_pointcloud2_message(h, encoded.layout, encoded.data, big);
    const msg::PointCloud2Message m = ros2::decode_pointcloud2_message(pc.data(), pc.size(), "pc");
    EXPECT_EQ(m.header.sec, 1234);
    EXPECT_EQ(m.header.nsec, 567800000u);
    EXPECT_EQ(m.header.frame_id, "os_lidar");
    EXPECT_EQ(m.layout.width, 2u);
    ASSERT_EQ(m.layout.fields.size(), encoded.layout.fields.size());
    const PointCloud back = decode_pointcloud2(m.layout, pc.data() + m.data_offset, m.data_size);
    EXPECT_EQ(back.points, cloud.points) << big;
    EXPECT_EQ(back.intensity, cloud.intensity) << big;
    EXPECT_EQ(ros2::decode_header(pc.data(), pc.size(), "pc").frame_id, "os_lidar");

    const Pose pose = pose_xyz_q(0.5, -1.5, 2.0, Eigen::Quaterniond(0.9, 0.1, -0.2, 0.3));
    const msg::PoseMessage odom{h, "base_link", pose};
    for (const auto& [bytes, decode] : {std::pair{ros2::encode_odometry(odom, big), &ros2::decode_odometry},
                                        std::pair{ros2::encode_pose_stamped(odom, big), &ros2::decode_pose_stamped},
                                        std::pair{ros2::encode_pose_with_covariance_stamped(odom, big),
                                                  &ros2::decode_pose_with_covariance_stamped}}) {
      const msg::PoseMessage back_pose = decode(bytes.data(), bytes.size(), "pose");
      EXPECT_EQ(back_pose.header.nsec, h.nsec);
      EXPECT_LT((back_pose.pose.matrix() - pose.matrix()).cwiseAbs().maxCoeff(), 1e-12);
    }
    EXPECT_EQ(
        ros2::decode_odometry(ros2::encode_odometry(odom, big).data(), ros2::encode_odometry(odom, big).size(), "o")
            .child_frame_id,
        "base_link");

    const msg::Imu imu{h, {0.1, 0.2, 0.3}, {0.0, 0.5, 9.8}};
    const std::vector<std::uint8_t> imu_bytes = ros2::encode_imu(imu, big);
    const msg::Imu back_imu = ros2::decode_imu(imu_bytes.data(), imu_bytes.size(), "imu");
    EXPECT_EQ(back_imu.angular_velocity, imu.angular_velocity);
    EXPECT_EQ(back_imu.linear_acceleration, imu.linear_acceleration);
  }
}

TEST(Ros2Messages, HostileMessagesAreOneSentence) {
  msg::Header h;
  h.frame_id = "lidar";
  PointCloud cloud;
  cloud.points = {{1.f, 2.f, 3.f}};
  const EncodedPointCloud2 encoded = encode_pointcloud2(cloud);
  std::vector<std::uint8_t> pc = ros2::encode_pointcloud2_message(h, encoded.layout, encoded.data);
  // Every cut is an error, never a read past the end.
  for (std::size_t cut = 0; cut + 4 < pc.size(); ++cut) {
    EXPECT_THROW(ros2::decode_pointcloud2_message(pc.data(), cut, "pc"), Error) << cut;
  }
  // A data sequence that claims more bytes than the message has.
  const std::size_t data_length_at = pc.size() - encoded.data.size() - 1 - 4;
  pc[data_length_at + 1] = 0x7F;
  EXPECT_NE(error_of([&] {
              ros2::decode_pointcloud2_message(pc.data(), pc.size(), "bag: /points message 0");
            }).find("bag: /points message 0: data holds 32528 elements"),
            std::string::npos);

  // A zero quaternion (many drivers' "unknown") and a NaN position.
  const std::vector<std::uint8_t> zero = ros2::encode_pose_stamped({h, "", Pose::Identity()});
  std::vector<std::uint8_t> no_rotation = zero;
  std::fill(no_rotation.end() - 32, no_rotation.end(), 0);
  EXPECT_NE(error_of([&] {
              ros2::decode_pose_stamped(no_rotation.data(), no_rotation.size(), "gt");
            }).find("gt: pose.orientation (0.000000, 0.000000, 0.000000, 0.000000) is not a unit quaternion"),
            std::string::npos);
  std::vector<std::uint8_t> nan = zero;
  const double not_a_number = std::nan("");
  std::memcpy(nan.data() + nan.size() - 56, &not_a_number, 8);
  EXPECT_NE(error_of([&] { ros2::decode_pose_stamped(nan.data(), nan.size(), "gt"); }).find("not a finite number"),
            std::string::npos);
  // A message of another type on the topic: bytes left over.
  const std::vector<std::uint8_t> with_covariance =
      ros2::encode_pose_with_covariance_stamped({h, "", Pose::Identity()});
  EXPECT_NE(error_of([&] {
              ros2::decode_pose_stamped(with_covariance.data(), with_covariance.size(), "gt");
            }).find("gt: 288 bytes left over after a geometry_msgs/msg/PoseStamped message (not of that type?)"),
            std::string::npos);
  // Nanoseconds of a second or more.
  std::vector<std::uint8_t> late = zero;
  late[8] = late[9] = late[10] = late[11] = 0xFF;
  EXPECT_NE(error_of([&] { ros2::decode_header(late.data(), late.size(), "m"); }).find("nanoseconds"),
            std::string::npos);
}

TEST(Ros2Messages, DefinitionsNameEveryTypeTheyUse) {
  const std::string odometry = ros2::message_definition(ros2::kOdometry);
  EXPECT_EQ(odometry.rfind("std_msgs/Header header\nstring child_frame_id\n", 0), 0u);
  for (const char* used :
       {"MSG: std_msgs/Header\n", "MSG: builtin_interfaces/Time\n", "MSG: geometry_msgs/PoseWithCovariance\n",
        "MSG: geometry_msgs/Pose\n", "MSG: geometry_msgs/Point\n", "MSG: geometry_msgs/Quaternion\n",
        "MSG: geometry_msgs/TwistWithCovariance\n", "MSG: geometry_msgs/Twist\n", "MSG: geometry_msgs/Vector3\n"}) {
    EXPECT_NE(odometry.find(std::string(80, '=') + "\n" + used), std::string::npos) << used;
  }
  EXPECT_NE(ros2::message_definition(ros2::kPointCloud2).find("MSG: sensor_msgs/PointField\nuint8 INT8    = 1\n"),
            std::string::npos);
  EXPECT_THROW(ros2::message_definition("std_msgs/msg/String"), Error);
}

}  // namespace
}  // namespace tsdf_mcl
