#pragma once
// What a test sends a localization node and hears back, whatever carries it: the core in the test's own process
// (direct_link.hpp) or the ROS 2 node over DDS (ros2/test). The scenarios (scenario.hpp) are written once against it.
#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include "node_messages.hpp"
#include "tsdf_mcl/core/point_cloud.hpp"

namespace tsdf_mcl::node::test {

// What the node said about one scan.
struct Heard {
  DiagnosticOut status;
  std::optional<PoseOut> pose;  // amcl_pose of the scan (none where the status says the scan was not used)
  bool used() const { return status.level != DiagnosticOut::kError; }
  std::string value(const std::string& key) const;
  std::size_t count(const std::string& key) const;  // a counter value; 0 where absent
};

class NodeLink {
 public:
  virtual ~NodeLink() = default;
  virtual void tf(const std::vector<TransformMsg>& transforms, bool is_static) = 0;
  // A cloud in `frame` stamped `stamp` on the first point topic.
  virtual void cloud(const PointCloud& cloud, const RawStamp& stamp, const std::string& frame) = 0;
  virtual void odometry(const OdometryMsg& odometry) = 0;
  virtual void imu(const ImuMsg& imu) = 0;
  virtual void clock(const RawStamp& now) = 0;  // /clock, where the node runs on sim time
  virtual void initial_pose(const InitialPoseMsg& pose) = 0;
  virtual void global_localization() = 0;  // the relocalization request
  // Waits for the node's status on the scan stamped `scan` (and its pose, where the status says it used the scan).
  // nullopt after `timeout`.
  virtual std::optional<Heard> heard(const RawStamp& scan, std::chrono::seconds timeout) = 0;
  // Waits for the tf map -> odom the node sent for the scan stamped `scan` (stamped that plus transform_tolerance).
  virtual std::optional<TransformOut> map_odom(const RawStamp& scan, std::chrono::seconds timeout) = 0;
  // Whether the node still runs.
  virtual bool alive() = 0;
};

}  // namespace tsdf_mcl::node::test
