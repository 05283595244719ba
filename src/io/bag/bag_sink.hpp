#pragma once
// Where BagWriter's messages go: a ROS 1 bag (src/io/rosbag/ros1_sink.cpp) or a rosbag2 recording
// (src/io/rosbag2/rosbag2_sink.cpp). BagWriter decides what to write (bag_writer.hpp); a sink encodes and stores it,
// each message at its header stamp, `time` seconds (> 0).
#include <string>
#include <vector>

#include "tsdf_mcl/io/bag_messages.hpp"
#include "tsdf_mcl/io/pointcloud2.hpp"

namespace tsdf_mcl::bag_io {

class BagSink {
 public:
  virtual ~BagSink() = default;  // without finish(), removes what it wrote
  // `is_static`: /tf_static, latched (ROS 1) or offered transient_local (ROS 2).
  virtual void write_tf(const std::string& topic, double time, const std::vector<msg::TransformStamped>& transforms,
                        bool is_static) = 0;
  virtual void write_points(const std::string& topic, double time, const msg::Header& header,
                            const EncodedPointCloud2& cloud) = 0;
  virtual void write_odometry(const std::string& topic, double time, const msg::PoseMessage& odometry) = 0;
  virtual void write_imu(const std::string& topic, double time, const msg::Imu& imu) = 0;
  // Completes the bag and moves it to its name; throws Error naming it where that fails.
  virtual void finish() = 0;
};

}  // namespace tsdf_mcl::bag_io
