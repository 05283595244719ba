#pragma once
// The messages of the node core (localization_core.hpp), as both transports hand them in and take them out: the
// fields of the ROS messages the node reads and writes, nothing of either ROS. The ROS 1 node (ros/) and the ROS 2
// node over DDS (ros2/) convert their own message types to and from these, field by field, and leave every check
// to the core (message_checks.hpp), so that both refuse the same messages for the same reasons.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/io/pointcloud2.hpp"

namespace tsdf_mcl::node {

// A ROS time as the message carried it: ROS 1's uint32 seconds (to 2^32 s, year 2106) and ROS 2's int32 seconds
// (which may be negative) both fit, nanoseconds unnormalized. message_checks.hpp says which stamps are usable.
struct RawStamp {
  std::int64_t sec = 0;
  std::uint32_t nanosec = 0;
};

// A usable time: nanoseconds of the ROS clock (0 .. 2^32 s fit with room to add and subtract).
struct Stamp {
  std::int64_t ns = 0;
  static Stamp from_seconds(double s) { return {static_cast<std::int64_t>(s * 1e9)}; }
  double seconds() const { return static_cast<double>(ns) * 1e-9; }
  bool zero() const { return ns == 0; }
  friend bool operator<(Stamp a, Stamp b) { return a.ns < b.ns; }
  friend bool operator<=(Stamp a, Stamp b) { return a.ns <= b.ns; }
  friend bool operator>(Stamp a, Stamp b) { return a.ns > b.ns; }
  friend bool operator>=(Stamp a, Stamp b) { return a.ns >= b.ns; }
  friend bool operator==(Stamp a, Stamp b) { return a.ns == b.ns; }
  friend bool operator!=(Stamp a, Stamp b) { return a.ns != b.ns; }
  // b - a in seconds.
  friend double seconds_between(Stamp a, Stamp b) { return static_cast<double>(b.ns - a.ns) * 1e-9; }
};

struct Header {
  RawStamp stamp;
  std::string frame_id;
};

// geometry_msgs Pose / Transform as sent: position (or translation) and the quaternion x, y, z, w, unchecked.
struct RawPose {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Vector4d orientation{0.0, 0.0, 0.0, 1.0};  // x, y, z, w
};

struct TransformMsg {  // geometry_msgs TransformStamped
  Header header;
  std::string child_frame_id;
  RawPose transform;
};

struct OdometryMsg {  // nav_msgs Odometry: the pose alone (the twist is not used)
  Header header;
  RawPose pose;
};

struct ImuMsg {  // sensor_msgs Imu: the specific force alone (gravity for the global search)
  Header header;
  Eigen::Vector3d linear_acceleration = Eigen::Vector3d::Zero();
};

struct InitialPoseMsg {  // geometry_msgs PoseWithCovarianceStamped
  Header header;
  RawPose pose;
};

// sensor_msgs PointCloud2: its layout and a view of its data, kept alive by `owner` (the transport's message), so
// that a cloud crosses into the core without a copy.
struct CloudMsg {
  Header header;
  PointCloud2Layout layout;
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;
  std::shared_ptr<const void> owner;
};

// What the core publishes, in the transports' terms.
struct PoseOut {  // amcl_pose
  Stamp stamp;
  std::string frame_id;
  Pose pose = Pose::Identity();
  std::array<double, 36> covariance{};  // x, y, z, rotation about the fixed X, Y, Z axes; row-major
};

struct PosesOut {  // particle clouds and the ranked hypotheses: poses with weights (shares), best first
  Stamp stamp;
  std::string frame_id;
  std::vector<Pose> poses;
  std::vector<double> weights;
};

struct TransformOut {  // tf parent -> child
  Stamp stamp;
  std::string parent, child;
  Pose pose = Pose::Identity();
};

struct DiagnosticOut {  // diagnostic_msgs DiagnosticArray with one DiagnosticStatus
  enum Level : std::uint8_t { kOk = 0, kWarn = 1, kError = 2 };
  Stamp stamp;
  Level level = kOk;
  std::string name, message, hardware_id;
  std::vector<std::pair<std::string, std::string>> values;
};

struct CloudOut {  // the map's surface for a viewer
  Stamp stamp;
  std::string frame_id;
  EncodedPointCloud2 cloud;
};

}  // namespace tsdf_mcl::node
